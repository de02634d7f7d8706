"""
An egg-crate on a sphere and on a mesh
======================================

The areal texture h(u) = A sin(k u1) sin(k u2) (A = 0.2 mm, 2 mm period) laid on a sphere whose
circumference holds 40 periods (R = 12.73 mm), and on a 1,280-facet triangle mesh of the same
sphere (trimesh's icosphere, its texture coordinates the sphere's). :mod:`haptex.objects`
displaces the base along its normal by the texture's height; algorithm A pushes along the base's
normal by the penetration. A sphere's q tends to the plane's as O(d/R), and the faceted mesh's
force differs from the analytic sphere's to first order in the facet size.
"""

import math
import pathlib
import tempfile

import matplotlib.pyplot as plt
import numpy as np
import trimesh

import haptex as hx
from haptex.objects import Mesh, Plane, Sphere, object_algorithm

egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
R = 40 * 2e-3 / (2 * math.pi)
sphere = Sphere(R)
ball = trimesh.creation.icosphere(subdivisions=3, radius=R)
# tilted so that no vertex lies on the sphere's poles (where its coordinates are singular), then
# centred like Sphere(R): its top at the origin
ball.apply_transform(trimesh.transformations.rotation_matrix(0.1234, [1.0, 0.3, 0.0]))
ball.apply_translation([0.0, 0.0, -R])
mesh = Mesh(ball, uv=sphere.local(np.asarray(ball.vertices))[0])

bases = {"plane": Plane(), "sphere R = 12.7 mm": sphere, "mesh, 1,280 facets": mesh}
algs = {name: object_algorithm("A", egg, base, 2000.0) for name, base in bases.items()}
for name, alg in algs.items():
    if name.startswith("mesh"):
        continue  # q on a mesh is reported by `haptex design`; its region grid takes longer
    print(f"{name}: q_A = {hx.characteristic_number(alg).value:.4f}")

# %%
# A stroke along u1 over the top, 0.1 mm inside the textured surface: the force's normal part.
u1 = np.linspace(-4e-3, 4e-3, 801)
u = np.stack([u1, np.full_like(u1, 0.5e-3)], axis=-1)
fig, ax = plt.subplots(figsize=(7, 3.8))
for name, alg in algs.items():
    base = bases[name]
    depth = egg.height_at(u) - 0.1e-3  # offset e along the normal: 0.1 mm below the textured surface
    p = (sphere if name.startswith("mesh") else base).point(u, depth)
    f = alg.force(p)
    ax.plot(u1 * 1e3, np.linalg.norm(f, axis=-1), label=name, lw=2.5 if name == "plane" else 1.2,
            ls=":" if name.startswith("sphere") else "-")
ax.set_xlabel("u1 (mm)")
ax.set_ylabel("|f| (N)")
ax.set_title("algorithm A, 0.1 mm inside the textured surface")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# A CAD part's STL states no unit and holds no texture coordinates: ``unit="mm"`` reads it in
# millimetres (``--mesh-unit mm``; the mesh's repr gives its extent), and ``uv="box"`` lays the
# texture by box projection (``--box-uv``): each triangle's coordinates on the plane across its
# normal's largest axis. The analyses lay one cell of the texture inside a chart of that map
# (``surface_range``; None where the cell at the origin lies on one already).
part = trimesh.creation.cylinder(radius=10.0, height=30.0, sections=24)  # (in mm, as CAD writes it)
with tempfile.TemporaryDirectory() as folder:
    stl = pathlib.Path(folder) / "part.stl"
    part.export(stl)
    cad = Mesh(stl, unit="mm", uv="box")
on_part = object_algorithm("A", egg, cad, 2000.0)
cell = on_part.surface_range
print(cad, "- the texture's cell analysed", "at the origin" if cell is None else
      "at u = " + " x ".join(f"{a * 1e3:.2f}-{b * 1e3:.2f}" for a, b in cell) + " mm")
