"""Holes: the boundary loops of a scan, their measurements, hole or border, and the loops that bound one
missing region together (bands, pants).
"""
