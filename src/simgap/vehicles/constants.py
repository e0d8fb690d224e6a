"""Physical constants every model of a vehicle shares (SI units)."""

GRAVITY = 9.81          # m/s^2
AIR_DENSITY = 1.204     # kg/m^3, dry air at 20 degC, sea level

# Bounds of a road vehicle: a data file beyond them describes no car on a public road.
MAX_LENGTH = 30.0       # m: longer than a 25.25 m EU road train
MAX_WIDTH = 4.0         # m: wider than an escorted oversize load (2.55 m EU and 2.6 m US without a permit)
MAX_SPEED = 150.0       # m/s (540 km/h): above the top speed of every road vehicle
MAX_MASS = 60000.0      # kg: above a 44 t EU and a 36 t US truck's gross weight
MAX_POWER = 2.0e6       # W: above the most powerful road car (about 1.5 MW)
