"""Physical constants every model of a vehicle shares (SI units)."""

GRAVITY = 9.81          # m/s^2
AIR_DENSITY = 1.204     # kg/m^3, dry air at 20 degC, sea level
