"""What a repair tells people: the paper's Table 1 as a dict, the HTML page, the pictures of each fill
and the 3D view.
"""
