#!/usr/bin/python3
"""Draws the README's picture: the bending actuator, deformed, coloured by the von Mises stress.

The input is softhom's own output of the shipped scene:

    OMP_NUM_THREADS=1 softhom macro studies/scenes/macro_bending_actuator.toml --out OUT -j 1 -q
    /usr/bin/python3 docs/figures/make_readme_figure.py OUT/fields.h5 docs/figures/bending_actuator.png

It reads the hex8 mesh, the displacement and the element von Mises stress of the last output step of
fields.h5 (the layout is in docs/outputs.md), draws the outer faces of the deformed mesh over the
undeformed outline, and writes a PNG. Debian's python3 with h5py, numpy and matplotlib.
"""
import argparse
from collections import Counter

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

# The six faces of a hex8 in the node order of fields.h5 (bottom 0-3, top 4-7).
HEX_FACES = ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))


def last_step(fields):
    """The group of the output step with the largest time."""
    steps = [fields[name] for name in fields if name.startswith("step_")]
    return max(steps, key=lambda group: group.attrs["time"])


def outer_faces(connectivity):
    """Faces that belong to one element only, with the index of that element."""
    count = Counter()
    owner = {}
    for element, nodes in enumerate(connectivity):
        for face in HEX_FACES:
            quad = tuple(nodes[i] for i in face)
            key = tuple(sorted(quad))
            count[key] += 1
            owner[key] = (quad, element)
    return [owner[key] for key, n in count.items() if n == 1]


def draw(coordinates, displacement, stress, faces, time_s, out_png):
    deformed = coordinates + displacement
    polygons = [deformed[list(quad)] for quad, _ in faces]
    values = np.array([stress[element] for _, element in faces])
    norm = matplotlib.colors.Normalize(vmin=0.0, vmax=np.percentile(values, 99))
    colours = plt.cm.viridis(norm(values))

    fig = plt.figure(figsize=(7.0, 5.2))
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(polygons, facecolors=colours, edgecolors="k", linewidths=0.15))
    outline = [coordinates[list(quad)] for quad, _ in faces]
    ax.add_collection3d(Poly3DCollection(outline, facecolors=(0, 0, 0, 0), edgecolors=(0.6, 0.6, 0.6, 0.25),
                                         linewidths=0.2))
    both = np.vstack([coordinates, deformed])
    lo, hi = both.min(axis=0), both.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    ax.view_init(elev=14, azim=-28)
    ax.set_xticks([round(lo[0]), 0, round(hi[0])])
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    mappable = plt.cm.ScalarMappable(norm=norm, cmap="viridis")
    fig.colorbar(mappable, ax=ax, shrink=0.6, pad=0.0, label="von Mises stress [MPa]")
    ax.set_title(f"bending actuator at t = {time_s:.0f} s (grey: undeformed)", fontsize=10)
    fig.savefig(out_png, dpi=90, bbox_inches="tight")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fields_h5", help="fields.h5 of `softhom macro studies/scenes/macro_bending_actuator.toml`")
    parser.add_argument("out_png")
    args = parser.parse_args()
    with h5py.File(args.fields_h5, "r") as fields:
        coordinates = fields["mesh/coordinates"][()]
        connectivity = fields["mesh/connectivity"][()]
        step = last_step(fields)
        draw(coordinates, step["displacement"][()], step["von_mises"][()], outer_faces(connectivity),
             float(step.attrs["time"]), args.out_png)


if __name__ == "__main__":
    main()
