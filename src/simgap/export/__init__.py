"""Other formats for runs, scenarios and search findings: the driven scenario as CommonRoad XML
(`driven_scenario`, written with every run), OpenDRIVE road networks (`opendrive`, exact for
generated roads; for recorded maps `road_topology` makes roads, links and junctions of the
lanelets and `lanelet_fit` fits each road), OpenSCENARIO replays of runs (`openscenario`), runs
as rerun recordings for its viewer (`rerun_recording`), the checks every written file passes
(`checks`), ASAM's Quality Checker (`quality_checker`) and one export end to end (`write`). It
reads run directories and scenario files; it never runs anything.

Nothing is imported here, so that the run loop can write driven scenarios without loading
scenariogeneration.
"""
