"""The aged look: reflectance models, corrosion and gilding maps, materials, the shader, the
renderer and the glTF export.
"""
