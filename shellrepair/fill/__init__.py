"""The fill: a patch for each hole or band (triangulate, refine, fair; tubes, pants, the Steiner layer),
the choice among candidates, the checks a patch must pass, and the merge into the scan.
"""
