"""Other formats for runs, scenarios and search findings: the driven scenario as CommonRoad XML
(`driven_scenario`, written with every run), OpenDRIVE road networks (`opendrive`, exact for
generated roads, fitted for recorded maps by `lanelet_fit`), OpenSCENARIO replays of runs
(`openscenario`), the checks every written file passes (`checks`) and one export end to end
(`write`). It reads run directories and scenario files; it never runs anything.

Nothing is imported here, so that the run loop can write driven scenarios without loading
scenariogeneration.
"""
