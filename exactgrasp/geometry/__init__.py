"""Geometry: rigid motions, closed solids and their shells, primitives, and the adapters of the
geometry libraries (manifold3d, coal / python-fcl) with the exact backend's predicates.

Modules here import only `exactgrasp.errors`, `exactgrasp.version`, `exactgrasp.cache`, each
other and third-party libraries (never hands, grasps or backends). No eager imports: import the
module you need (`from exactgrasp.geometry.solid import Solid`).
"""
