"""The vehicle catalogue: one YAML data file per vehicle in ``vehicles/data``."""

from simgap.vehicles.catalogue import Vehicle, VehicleLimits, load_vehicle, vehicle_names

__all__ = ["Vehicle", "VehicleLimits", "load_vehicle", "vehicle_names"]
