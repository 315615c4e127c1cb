"""Rotation kernels: the star matrix, quaternions, re-orthonormalisation.

Conventions (DESIGN.md): quaternions are (w, x, y, z), unit, body to world;
``R`` maps body to world, its columns are the body axes in world coordinates.
All functions are Numba-compiled and work on plain NumPy arrays so that both the
kernels and Python code (tests, scene building) can call them.
"""

from __future__ import annotations

import math
import os
import types

import numba
import numpy as np
from numba import njit

# One set of flags for every kernel. cache: the first run compiles, later runs load
# from __pycache__ (or NUMBA_CACHE_DIR), so tests and the CLI share compiled code.
# fastmath off: no reassociation or fused multiply-add, so results are the same bits
# on every run (STYLE 5.6 rule 6) and the engine can be compared with the reference.
# error_model "numpy": x / 0 gives inf or nan, as in NumPy, instead of raising;
# non-finite state is caught by the run's checks. PERF: Python's error model puts a
# test before every division; measured 25-35 % slower per step.
# _nrt (Numba's reference-counted runtime) is set, not inherited: a kernel compiled first from
# a NO_NRT caller would otherwise inherit NO_NRT's setting (Numba's flag inheritance).
JIT = dict(cache=True, nogil=True, fastmath=False, error_model="numpy", _nrt=True)
# Hot routines made of many small calls, without Numba's reference counting: the narrowphase's
# convex and mesh routines (GJK, EPA, face clipping), the broadphase's pair helpers, the joint
# solver and the ray casts. PERF: a compiled call increfs each array argument on entry and decrefs
# it on every exit (atomic operations); in the convex pile's narrowphase they were 64 % of the time
# (perf: NRT_incref 31 %, NRT_decref 33 %), in the humanoid's step 46 %. Rules for a NO_NRT
# function: it allocates nothing (scratch is lent by the caller: ``convex.convex_scratch``), and
# it returns no array (a view it made carries no reference; an NRT caller would drop one it never
# got). tests/test_reference_counting.py and tests/collision/test_narrowphase_kernel.py check it.
NO_NRT = dict(JIT, _nrt=False)


_threads_started_in = None  # the process that has started Numba's thread pool (start_threads)


def start_threads():
    """Start Numba's thread pool, once per process, before a compiled function that is not itself
    parallel calls one that is (the fused substeps call the contact solve's, the tree sweeps their
    groups'). Numba starts the pool only when a parallel function is compiled or called through its
    own dispatcher: called from inside a kernel before that, such a function crashed (a segmentation
    fault: found by tests/physics/test_kinematic.py). ``numba.get_num_threads`` starts it (0.6 us a
    call; this check 0.1 us, measured); the process id makes a forked child start its own."""
    global _threads_started_in
    pid = os.getpid()
    if _threads_started_in != pid:
        numba.get_num_threads()
        _threads_started_in = pid


def serial_twin(kernel, name: str, flags: dict = JIT):
    """The Python function of the parallel Numba ``kernel`` compiled again without ``parallel`` under
    ``name`` (its ``prange`` loops run as ``range`` on the calling thread): for small inputs, where
    starting the threads costs more than the work. The same source, so the same arithmetic and
    bits. A function object of its own, so that Numba's on-disk cache keeps the two apart (the
    cache is keyed by the function's qualified name, not by its ``parallel`` flag)."""
    f = kernel.py_func
    twin = types.FunctionType(f.__code__, f.__globals__, name, f.__defaults__, f.__closure__)
    twin.__qualname__ = name
    twin.__doc__ = f"``{f.__name__}`` on the calling thread (``math3d.serial_twin``)."
    twin.__module__ = f.__module__
    return njit(**flags)(twin)


@njit(**NO_NRT)
def unit_tangent(nx, ny, nz):
    """A unit vector perpendicular to unit n (a tuple): n x the axis n leans on least, normalised.
    (The contact solver's friction tangents keep their own rule: their bits are in every run.)"""
    if abs(nx) <= abs(ny) and abs(nx) <= abs(nz):
        tx, ty, tz = 0.0, nz, -ny
    elif abs(ny) <= abs(nz):
        tx, ty, tz = -nz, 0.0, nx
    else:
        tx, ty, tz = ny, -nx, 0.0
    ln = math.sqrt(tx * tx + ty * ty + tz * tz)
    return tx / ln, ty / ln, tz / ln


@njit(**JIT)
def star(w):
    """The matrix w* of the cross product: ``star(w) @ a == cross(w, a)``.

    ERRATA 1: the slide prints ``[[0,-wz,-wy],[-wz,0,-wx],[-wy,-wx,0]]``; that
    matrix is symmetric and cannot be a cross product. Baraff 2001, eq. (2-8).

    Args:
        w: (3,) vector.
    Returns:
        (3, 3) skew-symmetric matrix.
    """
    m = np.zeros((3, 3))
    m[0, 1] = -w[2]
    m[0, 2] = w[1]
    m[1, 0] = w[2]
    m[1, 2] = -w[0]
    m[2, 0] = -w[1]
    m[2, 1] = w[0]
    return m


@njit(**JIT)
def quat_multiply(a, b):
    """Hamilton product a b of (w, x, y, z) quaternions, (4,) each."""
    out = np.empty(4)
    out[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3]
    out[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2]
    out[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1]
    out[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]
    return out


@njit(**JIT)
def quat_to_matrix_into(q, out):
    """Write the rotation matrix of unit quaternion ``q`` (4,) into ``out`` (3, 3).

    The formula assumes |q| = 1; callers keep q normalised.
    """
    w, x, y, z = q[0], q[1], q[2], q[3]
    out[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[0, 1] = 2.0 * (x * y - w * z)
    out[0, 2] = 2.0 * (x * z + w * y)
    out[1, 0] = 2.0 * (x * y + w * z)
    out[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[1, 2] = 2.0 * (y * z - w * x)
    out[2, 0] = 2.0 * (x * z - w * y)
    out[2, 1] = 2.0 * (y * z + w * x)
    out[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(**JIT)
def quat_to_matrix(q):
    """Rotation matrix (3, 3) of the unit quaternion q (4,)."""
    out = np.empty((3, 3))
    quat_to_matrix_into(q, out)
    return out


# ---------------------------------------------------------------------- 3x3 products without BLAS
# NumPy's ``@``, ``dot``, ``norm`` and ``linalg.inv`` on small arrays go through OpenBLAS, whose
# kernels are chosen by the CPU (Haswell's on AVX2, SkylakeX's on AVX-512) and round differently in
# the last bit: the same scene built on two machines started from other bits (a Convex cell's
# I^-1, measured 2026-12-04, tests/conftest.py). Scene building and the per-step Python use these
# instead: sums in index order, the same bits on every machine (and Numba's ``@`` calls BLAS too).
@njit(**JIT)
def mat_vec(A, v):
    """A v for A (3, 3), v (3,): (3,)."""
    out = np.empty(3)
    for i in range(3):
        out[i] = A[i, 0] * v[0] + A[i, 1] * v[1] + A[i, 2] * v[2]
    return out


@njit(**JIT)
def mat_t_vec(A, v):
    """A^T v for A (3, 3), v (3,): (3,)."""
    out = np.empty(3)
    for i in range(3):
        out[i] = A[0, i] * v[0] + A[1, i] * v[1] + A[2, i] * v[2]
    return out


@njit(**JIT)
def mat_mat(A, B):
    """A B for A, B (3, 3): (3, 3)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(**JIT)
def mat_t_mat(A, B):
    """A^T B for A, B (3, 3): (3, 3)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[0, i] * B[0, j] + A[1, i] * B[1, j] + A[2, i] * B[2, j]
    return out


@njit(**JIT)
def rotate_tensor(R, M):
    """R M R^T for R, M (3, 3): a body-frame tensor (inertia) in the world frame."""
    RM = mat_mat(R, M)
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = RM[i, 0] * R[j, 0] + RM[i, 1] * R[j, 1] + RM[i, 2] * R[j, 2]
    return out


@njit(**JIT)
def inverse3(M):
    """M^-1 for an invertible M (3, 3): the reciprocals of a diagonal M (exact as LAPACK's), else the
    adjugate over the determinant (an inertia tensor's condition number is at most a few hundred)."""
    out = np.zeros((3, 3))
    if M[0, 1] == 0.0 and M[0, 2] == 0.0 and M[1, 0] == 0.0 and M[1, 2] == 0.0 and M[2, 0] == 0.0 and M[2, 1] == 0.0:
        for i in range(3):
            out[i, i] = 1.0 / M[i, i]
        return out
    c00 = M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]
    c01 = M[1, 2] * M[2, 0] - M[1, 0] * M[2, 2]
    c02 = M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]
    det = M[0, 0] * c00 + M[0, 1] * c01 + M[0, 2] * c02
    out[0, 0] = c00 / det
    out[1, 0] = c01 / det
    out[2, 0] = c02 / det
    out[0, 1] = (M[0, 2] * M[2, 1] - M[0, 1] * M[2, 2]) / det
    out[1, 1] = (M[0, 0] * M[2, 2] - M[0, 2] * M[2, 0]) / det
    out[2, 1] = (M[0, 1] * M[2, 0] - M[0, 0] * M[2, 1]) / det
    out[0, 2] = (M[0, 1] * M[1, 2] - M[0, 2] * M[1, 1]) / det
    out[1, 2] = (M[0, 2] * M[1, 0] - M[0, 0] * M[1, 2]) / det
    out[2, 2] = (M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]) / det
    return out


@njit(**JIT)
def norm3(v):
    """|v| for v (3,) or (4,): the squares summed in index order."""
    s = 0.0
    for i in range(v.shape[0]):
        s += v[i] * v[i]
    return math.sqrt(s)


def rows_dot(points, n):
    """points . n without BLAS (``mat_vec``'s note): (P,) for points (P, 3) and n (3,); (P, M) for
    n (M, 3), one column per row of n. Element-wise products and sums, in index order."""
    points = np.asarray(points, dtype=float)
    n = np.asarray(n, dtype=float)
    if n.ndim == 1:
        return points[:, 0] * n[0] + points[:, 1] * n[1] + points[:, 2] * n[2]
    return points[:, 0, None] * n[None, :, 0] + points[:, 1, None] * n[None, :, 1] + points[:, 2, None] * n[None, :, 2]


@njit(**JIT)
def matrix_to_quat_into(R, out):
    """Unit quaternion (w >= 0) of rotation matrix R (3, 3), written into out (4,).

    Shepperd's method: take the largest of the four squared components to
    divide by, so the result is accurate for every rotation.
    """
    t = R[0, 0] + R[1, 1] + R[2, 2]
    if t >= R[0, 0] and t >= R[1, 1] and t >= R[2, 2]:
        s = math.sqrt(1.0 + t) * 2.0
        out[0] = 0.25 * s
        out[1] = (R[2, 1] - R[1, 2]) / s
        out[2] = (R[0, 2] - R[2, 0]) / s
        out[3] = (R[1, 0] - R[0, 1]) / s
    elif R[0, 0] >= R[1, 1] and R[0, 0] >= R[2, 2]:
        s = math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2]) * 2.0
        out[0] = (R[2, 1] - R[1, 2]) / s
        out[1] = 0.25 * s
        out[2] = (R[0, 1] + R[1, 0]) / s
        out[3] = (R[0, 2] + R[2, 0]) / s
    elif R[1, 1] >= R[2, 2]:
        s = math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2]) * 2.0
        out[0] = (R[0, 2] - R[2, 0]) / s
        out[1] = (R[0, 1] + R[1, 0]) / s
        out[2] = 0.25 * s
        out[3] = (R[1, 2] + R[2, 1]) / s
    else:
        s = math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1]) * 2.0
        out[0] = (R[1, 0] - R[0, 1]) / s
        out[1] = (R[0, 2] + R[2, 0]) / s
        out[2] = (R[1, 2] + R[2, 1]) / s
        out[3] = 0.25 * s
    n = math.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2 + out[3] ** 2)
    sign = -1.0 if out[0] < 0.0 else 1.0
    for k in range(4):
        out[k] = sign * out[k] / n


@njit(**JIT)
def matrix_to_quat(R):
    """Unit quaternion (4,) with w >= 0 of the rotation matrix R (3, 3)."""
    out = np.empty(4)
    matrix_to_quat_into(R, out)
    return out


@njit(**JIT)
def normalize_quat_inplace(q):
    """Scale q (4,) back to unit length (ERRATA 5: keep the layout on SO(3))."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    for k in range(4):
        q[k] /= n


@njit(**JIT)
def orthonormalize_inplace(R):
    """Gram-Schmidt on the columns of R (3, 3): the nearest-by-construction rotation.

    ERRATA 5: explicit Euler on ``dR/dt = w* R`` grows R by (1 + h^2 |w|^2)
    a step; this pulls it back onto SO(3). Columns are the body axes
    (Baraff 2001 §2.3), so the first axis keeps its direction, the second is
    made orthogonal to it, the third is their cross product (right-handed).
    ``tumble.reference.orthonormalize`` does the same arithmetic in plain Python.
    """
    n0 = math.sqrt(R[0, 0] ** 2 + R[1, 0] ** 2 + R[2, 0] ** 2)
    a0 = R[0, 0] / n0
    a1 = R[1, 0] / n0
    a2 = R[2, 0] / n0
    d = a0 * R[0, 1] + a1 * R[1, 1] + a2 * R[2, 1]
    b0 = R[0, 1] - d * a0
    b1 = R[1, 1] - d * a1
    b2 = R[2, 1] - d * a2
    n1 = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    b0 /= n1
    b1 /= n1
    b2 /= n1
    R[0, 0] = a0
    R[1, 0] = a1
    R[2, 0] = a2
    R[0, 1] = b0
    R[1, 1] = b1
    R[2, 1] = b2
    R[0, 2] = a1 * b2 - a2 * b1
    R[1, 2] = a2 * b0 - a0 * b2
    R[2, 2] = a0 * b1 - a1 * b0


@njit(**JIT)
def quat_exp_multiply_inplace(q, wx, wy, wz, h):
    """q <- exp(h/2 (0, w)) q: rotate q (4,) by the angle h|w| about the world axis w.

    Exact for constant world angular velocity w (rad/s) over h (s); leaves q
    unit (up to rounding) without any projection.
    """
    n = math.sqrt(wx * wx + wy * wy + wz * wz)
    half = 0.5 * h * n
    c = math.cos(half)
    # sin(half)/n, with its limit h/2 for tiny |w| (the series keeps full precision)
    if half > 1e-4:
        s = math.sin(half) / n
    else:
        s = 0.5 * h * (1.0 - half * half / 6.0)
    dw, dx, dy, dz = c, s * wx, s * wy, s * wz
    w, x, y, z = q[0], q[1], q[2], q[3]
    q[0] = dw * w - dx * x - dy * y - dz * z
    q[1] = dw * x + dx * w + dy * z - dz * y
    q[2] = dw * y - dx * z + dy * w + dz * x
    q[3] = dw * z + dx * y - dy * x + dz * w


@njit(**JIT)
def world_inertia_into(R, inertia_body_inv, out):
    """out = R Ibody^-1 R^T (3, 3), 1/(kg m^2), world: the inverse inertia of a body at
    orientation R (3, 3) body to world, from inertia_body_inv (3, 3) in the body frame (course:
    I^-1(t) = R(t) Ibody^-1 R(t)^T)."""
    for r in range(3):
        for c in range(3):
            acc = 0.0
            for a in range(3):
                for b in range(3):
                    acc += R[r, a] * inertia_body_inv[a, b] * R[c, b]
            out[r, c] = acc


def quat_from_euler_deg(angles_deg) -> np.ndarray:
    """Quaternion (4,) from intrinsic z-y'-x'' (yaw, pitch, roll) angles in degrees.

    ``euler_deg = [roll_x, pitch_y, yaw_z]`` as scene files give it; the
    rotation applied is Rz(yaw) Ry(pitch) Rx(roll), as in aerospace and ROS.
    """
    from scipy.spatial.transform import Rotation

    roll, pitch, yaw = (float(a) for a in angles_deg)
    xyzw = Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True).as_quat()
    q = np.array([xyzw[3], xyzw[0], xyzw[1], xyzw[2]])
    return q if q[0] >= 0 else -q


def random_quaternions(count: int, rng: np.random.Generator) -> np.ndarray:
    """(count, 4) uniformly distributed unit quaternions (Shoemake 1992)."""
    u1, u2, u3 = rng.random((3, count))
    a, b = np.sqrt(1 - u1), np.sqrt(u1)
    q = np.stack(
        [a * np.sin(2 * np.pi * u2), a * np.cos(2 * np.pi * u2), b * np.sin(2 * np.pi * u3), b * np.cos(2 * np.pi * u3)],
        axis=1,
    )
    return q


@njit(**JIT)
def argsort_stable(keys):
    """The stable ascending order (n,) int64 of ``keys`` (n,): what ``np.argsort(keys,
    kind="stable")`` returns for keys without NaN (bottom-up merge sort; ties keep index order).

    COMPILE: Numba's own argsort and sort took 3.4 s of a first contact run's compile (the
    broadphase's two sorts); this one compiles in a fraction of that and gives the same order.
    """
    n = keys.shape[0]
    order = np.arange(n)
    if n < 2:
        return order
    src = order
    dst = np.empty(n, dtype=np.int64)
    width = 1
    while width < n:
        for lo in range(0, n, 2 * width):
            mid = min(lo + width, n)
            hi = min(lo + 2 * width, n)
            i, j, k = lo, mid, lo
            while i < mid and j < hi:
                if keys[src[j]] < keys[src[i]]:  # strictly smaller: a tie keeps the left (earlier) index
                    dst[k] = src[j]
                    j += 1
                else:
                    dst[k] = src[i]
                    i += 1
                k += 1
            while i < mid:
                dst[k] = src[i]
                i += 1
                k += 1
            while j < hi:
                dst[k] = src[j]
                j += 1
                k += 1
        src, dst = dst, src
        width *= 2
    return src
