"""Per-ray hashes of the kernel: the shutter time of motion blur (stratified per pixel, in a
permuted order) and the integer hash both backends share (``renderer.rays.lowbias32``)."""

from __future__ import annotations

from incandescent._jit import drjit_module


def blurs(spec, volume) -> bool:
    """Does this render blur motion (a shutter is set and the volume has a velocity grid)?"""
    return spec.shutter_s is not None and getattr(volume, "velocity_m_s", None) is not None


#: Salts XORed into the seed's key for the hashes of the shutter time (independent of the jitter).
_TIME_SALT, _STRATUM_SALT = 0x68E31DA4, 0xB5297A4D


def shutter_time(m, spec, x, y, index):
    """Each ray's time in s within the shutter: the N×N rays of a pixel take the N² strata of the
    interval in a pseudo-random order of their own (:func:`permute`: a time never follows the
    ray's place in the pixel, which would bias a moving edge), each at a hashed point in its
    stratum."""
    dr = drjit_module()
    s = spec.supersample
    strata = s * s
    sub = (x % s) * s + (y % s)
    pixel = (x // s) * spec.height + (y // s)
    seed = lowbias32(pixel ^ dr.opaque(m.UInt, spec.key ^ _STRATUM_SALT))
    stratum = permute(m, sub, strata, seed)
    xi = m.Float(lowbias32(index ^ dr.opaque(m.UInt, spec.key ^ _TIME_SALT)) >> 8) * 2.0**-24
    u = (m.Float(stratum) + xi) * (1.0 / strata)
    low, high = (dr.opaque(m.Float, float(t)) for t in spec.shutter_s)
    return dr.fma(high - low, u, low)


def permute(m, i, count: int, seed):
    """Element i of a pseudo-random permutation of 0 … count − 1 chosen by ``seed`` (per lane):
    Kensler's hash with cycle walking ("Correlated Multi-Jittered Sampling", Pixar 2013, §3)."""
    dr = drjit_module()
    if count == 1:
        return m.UInt(0)
    w = (1 << (count - 1).bit_length()) - 1  # the smallest all-ones mask covering count − 1

    def scramble(i):
        i = i ^ seed
        i = i * 0xE170893D
        i = i ^ (seed >> 16)
        i = i ^ ((i & w) >> 4)
        i = i ^ (seed >> 8)
        i = i * 0x0929EB3F
        i = i ^ (seed >> 23)
        i = i ^ ((i & w) >> 1)
        i = i * (1 | (seed >> 27))
        i = i * 0x6935FA69
        i = i ^ ((i & w) >> 11)
        i = i * 0x74DCB303
        i = i ^ ((i & w) >> 2)
        i = i * 0x9E501CC3
        i = i ^ ((i & w) >> 2)
        i = i * 0xC860A3DF
        i = i & w
        return (i ^ (i >> 5),)

    (i,) = scramble(i)  # do … while (i >= count): walk the cycle back into range
    (i,) = dr.while_loop((i,), lambda i: i >= count, scramble, labels=("i",))
    return (i + seed) % count


def lowbias32(x):
    """The integer hash of ``rays.lowbias32`` on UInt32 lanes (multiplication wraps mod 2³²)."""
    x = x ^ (x >> 16)
    x = x * 0x7FEB352D
    x = x ^ (x >> 15)
    x = x * 0x846CA68B
    return x ^ (x >> 16)
