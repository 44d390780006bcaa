#!/usr/bin/env python3
"""Independent reference values for crates/bake/src/rng.rs (its tests quote this output).

Written from the specification in the module docs of `luxbake::rng`, with Python's
arbitrary-precision integers reduced mod 2^32 and bit reversal through a string: nothing is
shared with the Rust code. Run: python3 crates/bake/tools/rng_reference.py
"""

M = 0xFFFFFFFF


def pcg(v):
    s = (v * 747796405 + 2891336453) & M
    w = (((s >> ((s >> 28) + 4)) ^ s) * 277803737) & M
    return ((w >> 22) ^ w) & M


def hash_(texel, sample, pass_, seed):
    return pcg((texel + pcg((sample + pcg((pass_ + pcg(seed)) & M)) & M)) & M)


def reverse(x):
    return int(format(x, "032b")[::-1], 2)


def lk(x, k):
    x = (x + k) & M
    for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
        x ^= (x * c) & M
    return x


def owen(x, k):
    return reverse(lk(reverse(x), k))


def sobol1(i):
    # Dimension 1 from Pascal's triangle mod 2 (not from the recurrence the Rust code uses):
    # bit b of i contributes column b, whose entry in row r (counted from the top bit) is
    # C(b, r) mod 2, odd iff r's bits are a subset of b's (Lucas); columns combine by XOR.
    y = 0
    for b in range(32):
        if (i >> b) & 1:
            col = 0
            for r in range(32):
                if (r & b) == r:
                    col |= 1 << (31 - r)
            y ^= col
    return y


def sobol2_bits(texel, sample, pass_, seed):
    key = hash_(texel, 0, pass_, seed)
    i = owen(sample, key)
    kx = pcg(key)
    ky = pcg(kx)
    return owen(reverse(i), kx), owen(sobol1(i), ky)


def unit_bits(h):
    return h >> 8  # the uniform is this / 2^24


if __name__ == "__main__":
    print("directions", [hex(sobol1(1 << b)) for b in (0, 1, 2, 3, 4, 31)])
    for i in (3, 5, 0xFFFFFFFF):
        print(f"sobol1({i:#x}) = {sobol1(i):#010x}")
    print(f"lk(0x12345678, 0x9abcdef0) = {lk(0x12345678, 0x9ABCDEF0):#010x}")
    print(f"owen(0x12345678, 0x9abcdef0) = {owen(0x12345678, 0x9ABCDEF0):#010x}")
    for args in ((0, 0, 1, 0), (1, 2, 3, 4), (123456, 7, 1, 42), (5, 1000, 2, 0xDEADBEEF)):
        x, y = sobol2_bits(*args)
        print(f"sobol2_bits{args} = [{x:#010x}, {y:#010x}]; 24-bit {unit_bits(x):#08x} {unit_bits(y):#08x}")
