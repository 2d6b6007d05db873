"""The scan as data: the Mesh type, reading and writing files, cleaning, topology, and the geometry
the later stages ask of it (crossings, distances, the read-only index of a scan).
"""
