"""Reads a `lamina run --record DIR` recording with meshio, an independent VTK reader, and
prints one JSON line per frame listed in DIR/run.pvd (tests/tests/record.rs checks them).

Usage: python3 read_recording.py DIR/run.pvd NODE
(NODE: a node whose displacement is printed as "probe", m)
"""

import json
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np


def tet_volumes(p, t):
    """Signed volumes of tetrahedra t (k x 4 node indices) at points p."""
    a, b, c, d = (p[t[:, i]] for i in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0


def cell_volumes(p, kind, nodes):
    """Signed volumes by VTK's corner order: a wedge is cut into three tetrahedra, a
    hexahedron into six, all around their cell's orientation. meshio reads a VTK wedge
    with its base triangle reversed (the gmsh prism order, meshio's `vtk_to_meshio_order`),
    so a wedge's VTK order is restored first."""
    if kind == "wedge":
        nodes = nodes[:, [0, 2, 1, 3, 5, 4]]
    cuts = {
        "tetra": [[0, 1, 2, 3]],
        "wedge": [[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 5]],
        "hexahedron": [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]],
    }
    if kind not in cuts:
        return np.zeros(0)
    return sum(tet_volumes(p, nodes[:, c]) for c in cuts[kind])


def main():
    pvd = Path(sys.argv[1])
    probe = int(sys.argv[2])
    datasets = ET.parse(pvd).getroot().find("Collection").findall("DataSet")
    for ds in datasets:
        mesh = meshio.read(pvd.parent / ds.get("file"))
        p = mesh.points
        d = mesh.point_data["displacement"]
        v = mesh.point_data["velocity"]
        counts = {}
        volumes = []
        strain = []
        for block, s in zip(mesh.cells, mesh.cell_data["strain"]):
            counts[block.type] = counts.get(block.type, 0) + len(block.data)
            volumes.append(cell_volumes(p.astype(np.float64), block.type, block.data))
            strain.append(s)
        volumes = np.concatenate(volumes) if volumes else np.zeros(0)
        strain = np.concatenate(strain)
        layers = sorted(set(int(x) for x in np.concatenate(mesh.cell_data["layer"])))
        print(json.dumps({
            "time": float(ds.get("timestep")),
            "points": len(p),
            "cells": counts,
            "points_finite": bool(np.isfinite(p).all()),
            "velocity_finite": bool(np.isfinite(v).all()),
            "max_displacement": float(np.linalg.norm(d, axis=1).max()),
            "max_speed": float(np.linalg.norm(v, axis=1).max()),
            "probe": [float(c) for c in d[probe]],
            "min_volume": float(volumes.min()) if len(volumes) else 0.0,
            "strain_finite": bool(np.isfinite(strain).all()),
            "max_abs_strain": float(np.abs(strain).max()),
            "cell_layers": layers,
            "point_layers": sorted(set(int(x) for x in mesh.point_data["layer"])),
        }))


if __name__ == "__main__":
    main()
