"""Writes y.npy (200, 6) and x.npy (201, 12): one run of the coupled model in model.json (seed 4), the
data of the README's `kfx blockdiag` and `kfx compare` examples. Usage: /usr/bin/python3 make_data.py"""
import json
import os

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
m = json.load(open(os.path.join(here, "model.json")))
n, c = m["n"], m["c"]
F, H, V, G = (np.array(m[k], float) for k in ("F", "H", "V", "G"))
R, U = float(m["R"]), float(m["U"])
rng = np.random.default_rng(4)
T = 200
x = rng.multivariate_normal(np.zeros(c), np.array(m["P0"], float), size=n)
xs, ys = [x.reshape(-1).copy()], []
for _ in range(T):
    u = rng.normal(0.0, np.sqrt(U))
    x = x @ F.T + rng.multivariate_normal(np.zeros(c), V, size=n) + (G[:, 0] * u)[None, :]
    xs.append(x.reshape(-1).copy())
    ys.append((x @ H.T)[:, 0] + rng.normal(0.0, np.sqrt(R), size=n))
np.save(os.path.join(here, "y.npy"), np.array(ys))
np.save(os.path.join(here, "x.npy"), np.array(xs))
