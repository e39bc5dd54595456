"""Write the tutorial's two objects as STL files in millimetres (``docs/tutorial.md``).

``objects/juice_box.stl``: a 30 x 50 x 70 mm box; ``objects/can.stl``: a cylinder 40 mm across
and 70 mm tall (48 sides), its axis along z. Both are centred on their own origin, as meshes
exported from CAD often are not: the tutorial places them with a pose. Run from anywhere:

    python examples/make_objects.py
"""

from pathlib import Path

import trimesh

HERE = Path(__file__).resolve().parent

if __name__ == "__main__":
    (HERE / "objects").mkdir(exist_ok=True)
    box = trimesh.creation.box(extents=(30.0, 50.0, 70.0))
    can = trimesh.creation.cylinder(radius=20.0, height=70.0, sections=48)
    for name, mesh in (("juice_box", box), ("can", can)):
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
        mesh.export(HERE / "objects" / f"{name}.stl")
        print(f"objects/{name}.stl: {len(mesh.faces)} triangles, {mesh.volume:.1f} mm^3")
