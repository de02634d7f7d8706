"""
The paper's Fig. 3 loop and the characteristic number
=====================================================

Algorithm A (vertical penetration into the grooved boundary) over the paper's sinusoid
(A = 0.8 mm, l = 1 mm, κ0 = 2 kN/m, Section V-A). Its characteristic number has the closed form
q = √(1 + (2πA/l)²) (Section IV-A), and around the closed path of Fig. 3 the field supplies
κ0 A²/2: A is not conservative.
"""

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx

tex = hx.Sinusoid(amplitude=0.8e-3, period=1e-3)
alg = hx.algorithm("A", tex, stiffness=2000.0)

q = hx.characteristic_number(alg)
path, expected, source = hx.paper_loop(alg)
work = hx.path_work(alg, path)
print(f"q = {q.value:.4f} (closed form {q.closed_form:.4f})")
print(f"loop energy {work:.4e} J; the paper: {expected:.4e} J ({source})")

# %%
# The loop over the textured boundary, with the force along it.
x = np.linspace(-0.25e-3, 0.5e-3, 400)
fig, ax = plt.subplots(figsize=(6, 4))
ax.plot(x * 1e3, tex.height(x) * 1e3, "k", label="textured boundary h(x)")
ax.plot(path[:, 0] * 1e3, path[:, -1] * 1e3, "C3-o", label=f"Fig. 3 loop: ΔE = {work * 1e3:.3f} mJ")
steps = np.linspace(0, 1, 9)[:-1]
p = np.concatenate([a + np.outer(steps, b - a) for a, b in zip(path[:-1], path[1:])])
f = alg.force(p)
ax.quiver(p[:, 0] * 1e3, p[:, -1] * 1e3, f[:, 0], f[:, -1], color="C0", width=0.004, scale=20,
          label="force along the loop (N)")
ax.set_xlabel("x (mm)")
ax.set_ylabel("z (mm)")
ax.set_title(f"algorithm A: q = {q.value:.3f}")
ax.legend(loc="lower right", fontsize=8)
fig.tight_layout()
