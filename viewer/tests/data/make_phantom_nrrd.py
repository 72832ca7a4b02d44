"""Writes the NRRD copies of phantom16.nii with pynrrd (an independent NRRD writer) for
viewer/tests/nrrd_volume.rs: `pip install pynrrd==1.1.3 && python3 make_phantom_nrrd.py`.

- phantom16.nrrd: the same uint8 voxels, gzip-encoded, attached, as 3D Slicer writes them
  (space left-posterior-superior, 6 mm space directions, origin -45 mm on every axis).
- phantom16.nhdr + phantom16.raw: the voxels times 4 as big-endian int16, raw, in a data
  file of their own, spacing given in metres (0.006 m), no origin.
"""

import struct

import nrrd
import numpy as np

with open("phantom16.nii", "rb") as f:
    raw = f.read()
vox_offset = int(struct.unpack("<f", raw[108:112])[0])
voxels = np.frombuffer(raw[vox_offset:vox_offset + 16**3], dtype=np.uint8)
# NIfTI stores x fastest; pynrrd's Fortran order keeps it so.
volume = voxels.reshape((16, 16, 16), order="F")

nrrd.write(
    "phantom16.nrrd",
    volume,
    {
        "space": "left-posterior-superior",
        "space directions": np.diag([6.0, 6.0, 6.0]),
        "space origin": np.array([-45.0, -45.0, -45.0]),
        "kinds": ["domain", "domain", "domain"],
        "encoding": "gzip",
    },
    index_order="F",
)

nrrd.write(
    "phantom16.nhdr",
    (volume.astype(np.int16) * 4).astype(">i2"),
    {
        "spacings": [0.006, 0.006, 0.006],
        "space units": ["m", "m", "m"],
        "encoding": "raw",
    },
    detached_header=True,
    index_order="F",
)
