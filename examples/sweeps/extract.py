"""Quantities of the example sweeps that no built-in extractor gives (docs/sweeps.md): each
function takes a run (cutsim.sweeps.Run: its folder, scene, parameters, per-step CSV columns and
last frame) and returns a number."""
import numpy as np


def crack_length(run):
    """Rest length of the crack at the end: the border grown since the start, halved (two lips
    per length of crack), less the notch cut at t = 0 (its two lips)."""
    final = run.final()
    tri, rest = final["triangles"], final["rest"]
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    unique, count = np.unique(e, axis=0, return_counts=True)
    border = unique[count == 1]
    length = float(np.linalg.norm(rest[border[:, 0]] - rest[border[:, 1]], axis=1).sum())
    size = run.scene["mesh"]["grid"]["size"]
    notch = run.scene["timeline"][0]["polyline"]
    notch_length = float(np.linalg.norm(np.subtract(notch[1], notch[0])))
    return (length - 2 * (size[0] + size[1]) - 2 * notch_length) / 2


def free_corner_height(run):
    """Height (z, m) at the last frame of the point whose rest position is the corner (1, 0, 0),
    the free corner farthest from the held ones' line."""
    final = run.final()
    i = int(np.argmin(np.linalg.norm(final["rest"] - np.array([1.0, 0.0, 0.0]), axis=1)))
    return float(final["position"][i, 2])
