"""The vehicle catalogue: one YAML data file per vehicle in ``vehicles/data``."""

from simgap.vehicles.catalogue import (
    DEFAULT_VEHICLE,
    Vehicle,
    VehicleLimits,
    is_vehicle_file,
    load_vehicle,
    vehicle_names,
)

__all__ = ["DEFAULT_VEHICLE", "Vehicle", "VehicleLimits", "is_vehicle_file", "load_vehicle", "vehicle_names"]
