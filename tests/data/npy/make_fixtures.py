"""Writes the .npy fixtures of tests/io/npy_test.cpp with real numpy (provenance of the committed bytes).

Run from this folder: python3 make_fixtures.py  (written with numpy 1.24.2). The tests do not need
numpy; they read the committed files and compare with the values below, which they repeat.
"""
import numpy as np
from numpy.lib import format as npf

# 2x3 float64 with values that are not short decimals, the smallest subnormal and a negative zero.
A = np.array([[0.1, -2.5, 5e-324], [3.0, np.pi, -0.0]], dtype="<f8")

np.save("f8_2x3.npy", A)                              # C order, version 1.0
np.save("f8_2x3_fortran.npy", np.asfortranarray(A))   # fortran_order: True
T = np.arange(24, dtype="<f8").reshape(2, 3, 4) * 0.5 - 3.0
np.save("f8_2x3x4.npy", T)
np.save("f8_2x3x4_fortran.npy", np.asfortranarray(T))
np.save("f8_scalar.npy", np.float64(2.75))
np.save("f8_vector5.npy", np.array([1.5, -1.0, 0.0, 1e10, -3.25]))
np.save("f8_empty_0x3.npy", np.zeros((0, 3)))
np.save("f4_vector.npy", np.array([0.1, -1.5, 3.0], dtype="<f4"))
np.save("i8_2x2.npy", np.array([[-(2**40), -1], [0, 2**40 + 3]], dtype="<i8"))
np.save("i4_vector.npy", np.array([-7, 0, 2147483647, -2147483648], dtype="<i4"))
np.save("u1_vector.npy", np.array([0, 1, 255], dtype="u1"))
np.save("b1_2x2.npy", np.array([[True, False], [False, True]]))
for version in [(2, 0), (3, 0)]:
    with open("f8_2x3_v%d.npy" % version[0], "wb") as f:
        npf.write_array(f, A, version=version)
np.save("f8_big_endian.npy", np.array([1.0, 2.0], dtype=">f8"))
np.save("c16_vector.npy", np.array([1 + 2j, 3 - 4j]))
np.save("object.npy", np.array([1, "a"], dtype=object), allow_pickle=True)
np.save("structured.npy", np.zeros(2, dtype=[("x", "<f8"), ("y", "<i4")]))
