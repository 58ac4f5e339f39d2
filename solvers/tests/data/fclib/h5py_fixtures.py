"""Write the FCLIB files of this folder with h5py (which bundles libhdf5), for the reader tests.

Each file holds one small problem in a layout FCLIB files come in: a local problem with W as
compressed rows in HDF5's default format, as triplets in the latest format (superblock 3, int64
scalars), and in two dimensions with groups that track creation order; a global problem with
chunked, shuffled and deflated datasets; and two with datasets declared far larger than the file.
solvers/tests/fclib_files.rs states what each holds.

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install h5py numpy
    /tmp/venv/bin/python h5py_fixtures.py
"""

import h5py
import numpy as np

# Two 3-D contacts: W (6 x 6) is diag(2, 2, 2, 1, 1, 1) with 0.1 coupling rows 1 and 2.
W = np.diag([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
W[1, 2] = W[2, 1] = 0.1
Q = [-2.0, -0.4, -0.02, -1.0, 2.0, 0.0]
MU = [0.5, 0.3]


def info(group, title):
    g = group.create_group("info")
    g["title"] = np.bytes_(title)
    g["description"] = np.bytes_("lcpbench reader test data written by h5py")
    g["math_info"] = np.bytes_("")


def sparse(group, a, form, itype, scalar=False):
    """CSparse's layout: form -1 compressed columns, -2 compressed rows, 0 triplets."""
    rows, cols = np.nonzero(a)
    order = np.lexsort((rows, cols)) if form == -1 else np.lexsort((cols, rows))
    rows, cols = rows[order], cols[order]
    x = a[rows, cols]
    nnz = len(x)
    if form == -1:
        p, i = np.searchsorted(cols, np.arange(a.shape[1] + 1)), rows
    elif form == -2:
        p, i = np.searchsorted(rows, np.arange(a.shape[0] + 1)), cols
    else:
        p, i = cols, rows
    nz = nnz if form >= 0 else form

    def one(name, v):
        group.create_dataset(name, data=np.array(v if scalar else [v], dtype=itype))

    one("m", a.shape[0])
    one("n", a.shape[1])
    one("nzmax", nnz)
    one("nz", nz)
    group.create_dataset("p", data=np.asarray(p, dtype=itype))
    group.create_dataset("i", data=np.asarray(i, dtype=itype))
    group.create_dataset("x", data=np.asarray(x, dtype=np.float64))


def local(path, form, itype, scalar=False, **file_args):
    with h5py.File(path, "w", **file_args) as f:
        g = f.create_group("fclib_local")
        g.create_dataset("spacedim", data=np.array(3 if scalar else [3], dtype=itype))
        sparse(g.create_group("W"), W, form, itype, scalar)
        v = g.create_group("vectors")
        v["q"] = np.array(Q)
        v["mu"] = np.array(MU)
        info(g, path)


local("local_csr.hdf5", -2, np.int32)
local("local_triplets_latest.hdf5", 0, np.int64, scalar=True, libver="latest")

# One 2-D contact: W = [[1, 0.25], [0.25, 0.5]], q = (-1, 0.1), mu = 0.4.
with h5py.File("local_2d.hdf5", "w", track_order=True) as f:
    g = f.create_group("fclib_local", track_order=True)
    g["spacedim"] = np.array([2], dtype=np.int32)
    sparse(g.create_group("W", track_order=True), np.array([[1.0, 0.25], [0.25, 0.5]]), -1, np.int32)
    v = g.create_group("vectors", track_order=True)
    v["q"] = np.array([-1.0, 0.1])
    v["mu"] = np.array([0.4])

# A global problem: M (5 x 5, tridiagonal SPD), H (5 x 3), one 3-D contact.
M = np.diag([3.0, 4.0, 5.0, 6.0, 7.0]) - np.eye(5, k=1) - np.eye(5, k=-1)
H = np.array([[1, 0, 0], [0.5, 1, 0], [0, 0, 1], [0, -0.5, 0], [0.2, 0, 0.3]])
with h5py.File("global_deflate.hdf5", "w") as f:
    g = f.create_group("fclib_global")
    g["spacedim"] = np.array([3], dtype=np.int32)
    sparse(g.create_group("M"), M, -1, np.int32)
    sparse(g.create_group("H"), H, 0, np.int32)
    v = g.create_group("vectors")
    for name, data in [("f", [1.0, -2.0, 0.5, 0.0, 1.5]), ("w", [0.1, -0.2, 0.3]), ("mu", [0.6])]:
        v.create_dataset(name, data=np.array(data), chunks=(min(2, len(data)),), shuffle=True, compression="gzip")
    for name in ["x", "i", "p"]:
        data = g["M"][name][()]
        del g["M"][name]
        g["M"].create_dataset(name, data=data, chunks=(4,), compression="gzip")
    info(g, "global")

# Hostile sizes: datasets declared far larger than the file holds, never written, so HDF5 would
# hand back fill values (8 GB of them for q, 8 TB for f) to a reader that trusts the shape.
with h5py.File("declared_huge.hdf5", "w") as f:
    g = f.create_group("fclib_local")
    g["spacedim"] = np.array([3], dtype=np.int32)
    sparse(g.create_group("W"), W, -1, np.int32)
    v = g.create_group("vectors")
    v.create_dataset("q", shape=(10**9,), dtype=np.float64)
    v["mu"] = np.array(MU)
with h5py.File("declared_huge_deflate.hdf5", "w") as f:
    g = f.create_group("fclib_global")
    g["spacedim"] = np.array([3], dtype=np.int32)
    sparse(g.create_group("M"), M, -1, np.int32)
    sparse(g.create_group("H"), H, 0, np.int32)
    v = g.create_group("vectors")
    v.create_dataset("f", shape=(2**40,), chunks=(2**16,), compression="gzip", dtype=np.float64)
    v["w"] = np.array([0.1, -0.2, 0.3])
    v["mu"] = np.array([0.6])
