"""OpenDRIVE road networks in: an .xodr file read into a CommonRoad lanelet network (`network`),
keeping each road's elevation and superelevation (`origin`), and a scenario on it from a start and
a goal (`scenario`).

The reader is simgap's own, on lxml (`document`), with the reference line's geometry evaluated in
`reference_line` and the lanes' borders sampled in `lanes`. What cannot be a road is refused and a
link that leads nowhere dropped with a warning (`checks`, where the rule is).
"""
