"""Write turbulent_08.bts (and ../turbulent_11p4/turbulent_11p4.bts): a
synthetic turbulent full-field wind in TurbSim's binary format, for
InflowWind WindType 3 (OpenFAST 5.0).

    python3 make_wind.py            # (re)write turbulent_08.bts beside this script
    python3 make_wind.py --check    # regenerate in memory, compare with the committed file
    python3 make_wind.py --stats    # the field's statistics at the hub and over the rotor disc
    python3 make_wind.py --case=turbulent_11p4 [--check | --stats]   # the other case's field
    python3 make_wind.py --seed=N --stats      # another seed (nothing written with --stats)

The committed .bts is the reference; this script documents how it was made
(numpy only, fixed seed). Regenerating on another machine or numpy version may
differ in the last int16 count, since the cosines' last bits are not portable.

Field
- Grid 15 x 15 points, dy = dz = 10 m: y = -70 ... 70 m, z = 20 ... 160 m (the
  hub, 90 m, is the grid node iy = 7, iz = 7 counting from 0); dt = 0.1 s,
  701 steps (70 s).
- Mean: u = 8 m/s (z / 90 m)^0.2 (power law), v = w = 0.
- Fluctuations of each component: a sum of 80 log-spaced frequency bins over
  0.01-2 Hz, 20 random modes per bin (frequency uniform in log within the bin,
  random phase), with amplitudes from the IEC Kaimal spectrum
  S(f) = 4 sigma^2 (L/U) / (1 + 6 f L/U)^(5/3), L = 340.2, 113.4, 27.72 m for
  u, v, w (8.1, 2.7, 0.66 x Lambda = 42 m). Each mode's phase varies linearly
  across the grid, phase = 2 pi f t + k . (y, z) + phi, with a random direction
  in the y-z plane and a random wavenumber magnitude drawn so that the expected
  cross-correlation of two points r apart at frequency f is exp(-r / l(f)),
  1 / l = 12 sqrt((f / U)^2 + (0.12 / Lc)^2), Lc = 340.2 m: the IEC
  exponential coherence, in expectation (the 2-D Fourier transform of
  exp(-r / l) gives |k| with P(|k| < k) = 1 - 1 / sqrt(1 + (k l)^2)).
- Each component's fluctuations are shifted by one constant so their
  space-time mean over the grid is 0, and scaled by one factor so their
  space-time standard deviation over the grid is 0.88, 0.704, 0.44 m/s
  (11 % of 8 m/s for u, 0.8 and 0.5 times that for v and w).
- Seed 1 gives at the hub node (y = 0, z = 90 m), over the whole file: mean
  u, v, w 7.878, -0.003, 0.012 m/s, std 0.846, 0.646, 0.455 m/s (u TI
  10.7 %); over the file times the 40-s OpenFAST run reads there (8.75 to
  48.75 s, InflowWind's Wind1Vel*): mean 7.77, 0.09, 0.02 m/s, std 0.93, 0.63,
  0.43 m/s. The std of u over the 70 s differs from point to point (0.56 to
  1.37 m/s over the grid: most of the Kaimal u variance lies below 0.05 Hz,
  only a few cycles in 70 s); the rotor-disc (r < 63 m) average of u has std
  0.26 m/s. Over 8 seeds the mean correlation of u, v, w between grid points
  10 m apart is 0.50, 0.46, 0.31 (the band-limited IEC values 0.51, 0.45, 0.31).
- turbulent_11p4 (`--case=turbulent_11p4`): the same with u = 11.4 m/s at the hub,
  TI 15 % (std 1.71, 1.368, 0.855 m/s over the grid), 801 steps (80 s), seed 4,
  chosen among seeds 1-8 for the largest rotor-disc average fluctuation (std of
  the disc-average u over the whole file 0.73, 0.54, 0.50, 1.00, 0.83, 0.96, 0.49,
  0.82 m/s for seeds 1-8): at the hub mean u 11.27 m/s, std 1.87 m/s (TI 16.6 %),
  v, w std 1.50, 0.72 m/s; over the file times the 60-s run reads at the hub
  (6.1 to 66.1 s) the disc-average u has mean 11.24 m/s and std 1.11 m/s, so
  the rotor passes through the torque law's regions 2, 2.5 and 3.
- InflowWind (file ID 7, not periodic) puts the file's time 0 at
  x = InitXPosition = half the grid width = 70 m downwind: a point at x reads
  file time t + (70 m - x) / 8 m/s (the hub, x = 0, file time t + 8.75 s; the
  blades, about 5 m upwind, t + 9.4 s), so TMax 40 s reads up to about 49.5 s
  of the 70 s. The grid's y runs from -70 m (index 1) to +70 m.

File (as TurbSim's WrBinTURBSIM writes it and InflowWind's IfW_TurbSim_Init
reads it, little-endian, no record markers)
- int16 file ID 7 (not periodic; 8 would be periodic)
- int32 NZ, NY, NTwr, NT; float32 dz, dy, dt, U_hub (8.0), hub height (90),
  z of the grid's bottom row (20)
- float32 slope and offset for u, then v, then w; int32 length of the
  description, then its ASCII bytes
- per time step, int16: the grid, z slowest, then y, components u, v, w
  fastest; then the tower points (y = 0, z = z_bottom - k dz, k = 0, 1, ...,
  down to just above the ground: here 2 points, 20 m and 10 m, as TurbSim
  makes them for this grid; the first repeats the grid's bottom-centre node)
  with u, v, w fastest
- velocity = (int16 - offset) / slope, slope = 65535 / (max - min) and
  offset = -32768 - slope * min over the grid and tower points of the file.
"""
import struct
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
#: the fields this script writes: {case: (seed, steps, hub wind [m/s], u turbulence
#: intensity, the case's TMax [s])}
CASES = {"turbulent_08": (1, 701, 8.0, 0.11, 40.0), "turbulent_11p4": (4, 801, 11.4, 0.15, 60.0)}
CASE = next((a.split("=", 1)[1] for a in sys.argv[1:] if a.startswith("--case=")), "turbulent_08")
TARGET = HERE.parent / CASE / f"{CASE}.bts"

SEED, NT, U_HUB, TI, TMAX = CASES[CASE]
SEED = int(next((a.split("=", 1)[1] for a in sys.argv[1:] if a.startswith("--seed=")), SEED))
NY = NZ = 15
DY = DZ = 10.0
DT = 0.1
HUB_HT = 90.0
Z_BOTTOM = HUB_HT - 0.5 * DZ * (NZ - 1)          # 20 m
ALPHA = 0.2
SIGMA = (TI * U_HUB, 0.8 * TI * U_HUB, 0.5 * TI * U_HUB)
LAMBDA1 = 42.0
L_KAIMAL = (8.1 * LAMBDA1, 2.7 * LAMBDA1, 0.66 * LAMBDA1)
L_COH = 8.1 * LAMBDA1
F_MIN, F_MAX, N_BINS, MODES_PER_BIN = 0.01, 2.0, 80, 20
TOLERANCE = 1e-4                                   # TurbSim's
DESCRIPTION = ("Generated by make_wind.py (modesel tests, %s): synthetic "
               "Kaimal/IEC-coherence random-mode field, numpy seed %d." % (CASE, SEED))


def grid():
    """Coordinates: the grid (NZ, NY) and the tower points (NTwr,)."""
    y = -0.5 * DY * (NY - 1) + DY * np.arange(NY)
    z = Z_BOTTOM + DZ * np.arange(NZ)
    n_twr = int((Z_BOTTOM - TOLERANCE) / DZ) + 1   # TurbSim's count of tower points
    z_twr = Z_BOTTOM - DZ * np.arange(n_twr)
    return y, z, z_twr


def kaimal(f, sigma, length):
    x = length / U_HUB
    return 4.0 * sigma**2 * x / (1.0 + 6.0 * f * x) ** (5.0 / 3.0)


def fluctuations(rng, yp, zp, t):
    """Fluctuations (NT, npoints, 3) at the points (yp, zp)."""
    edges = np.geomspace(F_MIN, F_MAX, N_BINS + 1)
    out = np.empty((t.size, yp.size, 3))
    for ic in range(3):
        lo = np.repeat(edges[:-1], MODES_PER_BIN)
        hi = np.repeat(edges[1:], MODES_PER_BIN)
        f = lo * (hi / lo) ** rng.random(lo.size)
        amp = np.sqrt(2.0 * kaimal(f, SIGMA[ic], L_KAIMAL[ic]) * (hi - lo) / MODES_PER_BIN)
        phi = 2.0 * np.pi * rng.random(f.size)
        theta = 2.0 * np.pi * rng.random(f.size)
        ell = 1.0 / (12.0 * np.sqrt((f / U_HUB) ** 2 + (0.12 / L_COH) ** 2))
        kmag = np.sqrt((1.0 - rng.random(f.size)) ** -2 - 1.0) / ell
        space = (np.outer(yp, kmag * np.cos(theta)) + np.outer(zp, kmag * np.sin(theta))
                 + phi)                                            # (npoints, modes)
        temporal = np.exp(2j * np.pi * np.outer(t, f))             # (NT, modes)
        out[:, :, ic] = (temporal @ (amp * np.exp(1j * space)).T).real
    return out


def make_field():
    """Velocities: grid (NT, NZ, NY, 3) and tower (NT, NTwr, 3), m/s."""
    rng = np.random.default_rng(SEED)
    y, z, z_twr = grid()
    t = DT * np.arange(NT)
    yy, zz = np.meshgrid(y, z)                                      # (NZ, NY)
    extra = z_twr[1:]                                               # tower points below the grid
    yp = np.concatenate([yy.ravel(), np.zeros(extra.size)])
    zp = np.concatenate([zz.ravel(), extra])
    fl = fluctuations(rng, yp, zp, t)
    ngrid = NY * NZ
    for ic in range(3):                                             # normalize over the grid
        g = fl[:, :ngrid, ic]
        fl[:, :, ic] = (fl[:, :, ic] - g.mean()) * (SIGMA[ic] / g.std())
    mean_u = U_HUB * (zp / HUB_HT) ** ALPHA
    fl[:, :, 0] += mean_u
    vel = fl[:, :ngrid].reshape(NT, NZ, NY, 3)
    twr = np.concatenate([vel[:, 0, NY // 2][:, None], fl[:, ngrid:]], axis=1)
    return vel, twr


def nint(x):
    """Fortran NINT (halves away from zero)."""
    return np.sign(x) * np.floor(np.abs(x) + 0.5)


def encode(vel, twr):
    """The .bts bytes, as TurbSim's WrBinTURBSIM writes them."""
    ntwr = twr.shape[1]
    allv = np.concatenate([vel.reshape(NT, -1, 3), twr], axis=1)
    vmin, vmax = allv.min(axis=(0, 1)), allv.max(axis=(0, 1))
    slope = np.float32(65535.0) / (vmax - vmin).astype(np.float32)
    offset = np.float32(-32768.0) - slope * vmin.astype(np.float32)
    raw = slope * allv.astype(np.float32) + offset                  # float32, as TurbSim
    raw = nint(np.clip(raw, -32768.0, 32767.0)).astype("<i2")
    desc = DESCRIPTION.encode("ascii")
    header = struct.pack("<h4i6f6fi", 7, NZ, NY, ntwr, NT, DZ, DY, DT, U_HUB, HUB_HT, Z_BOTTOM,
                         slope[0], offset[0], slope[1], offset[1], slope[2], offset[2], len(desc))
    return header + desc + raw.tobytes()


def read_bts(path):
    """Read a .bts as InflowWind does: (header dict, grid (NT, NZ, NY, 3), tower (NT, NTwr, 3))."""
    data = Path(path).read_bytes()
    fmt = "<h4i6f6fi"
    vals = struct.unpack_from(fmt, data)
    keys = ("file_id nz ny ntwr nt dz dy dt u_hub hub_ht z_bottom "
            "slope_u off_u slope_v off_v slope_w off_w ndesc").split()
    h = dict(zip(keys, vals))
    pos = struct.calcsize(fmt)
    h["description"] = data[pos:pos + h["ndesc"]].decode("ascii")
    pos += h["ndesc"]
    nz, ny, ntwr, nt = h["nz"], h["ny"], h["ntwr"], h["nt"]
    raw = np.frombuffer(data, "<i2", count=nt * (nz * ny + ntwr) * 3, offset=pos)
    raw = raw.reshape(nt, nz * ny + ntwr, 3).astype(np.float32)
    slope = np.array([h["slope_u"], h["slope_v"], h["slope_w"]], np.float32)
    off = np.array([h["off_u"], h["off_v"], h["off_w"]], np.float32)
    v = (raw - off) / slope
    assert pos + raw.size * 2 == len(data), "trailing bytes"
    return h, v[:, :nz * ny].reshape(nt, nz, ny, 3), v[:, nz * ny:]


def stats(vel, t0=70.0 / U_HUB, t1=70.0 / U_HUB + TMAX):
    """Print the hub node's and the rotor disc's (r < 63 m, the grid nodes' plain mean) u statistics over
    the whole file and over the file times the OpenFAST run reads at the hub (t0 to t1)."""
    y, z, _ = grid()
    yy, zz = np.meshgrid(y, z)
    disc = np.hypot(yy, zz - HUB_HT) < 63.0
    t = DT * np.arange(NT)
    hub = vel[:, NZ // 2, NY // 2]
    rav = vel[:, disc, 0].mean(axis=1)
    w = (t >= t0) & (t <= t1)
    print("seed %d: %d disc nodes; hub u mean %.3f std %.3f (TI %.1f %%), v,w std %.3f %.3f; "
          "disc-avg u std %.3f (whole), window %.1f-%.1f s: hub u mean %.3f std %.3f, disc-avg u mean %.3f std %.3f"
          % (SEED, disc.sum(), hub[:, 0].mean(), hub[:, 0].std(), 100 * hub[:, 0].std() / hub[:, 0].mean(),
             hub[:, 1].std(), hub[:, 2].std(), rav.std(), t0, t1, hub[w, 0].mean(), hub[w, 0].std(),
             rav[w].mean(), rav[w].std()))


def main():
    vel, twr = make_field()
    if "--stats" in sys.argv[1:]:
        stats(vel)
        return 0
    blob = encode(vel, twr)
    if "--check" in sys.argv[1:]:
        old = TARGET.read_bytes()
        same = old == blob
        _, gold, _ = read_bts(TARGET)
        print(TARGET.name, "identical" if same else
              "differs: max |du| %.2e m/s" % np.abs(gold - vel).max())
        return 0 if same else 1
    TARGET.write_bytes(blob)
    h, g, tw = read_bts(TARGET)
    step = 1.0 / np.array([h["slope_u"], h["slope_v"], h["slope_w"]])
    err = np.abs(g - vel).max(axis=(0, 1, 2))
    assert np.all(err <= 0.51 * step + 1e-6 * np.abs(vel).max()), (err, step)
    hub = g[:, NZ // 2, NY // 2]
    print(TARGET.name, TARGET.stat().st_size, "bytes; hub mean", hub.mean(axis=0).round(3),
          "std", hub.std(axis=0).round(3))
    return 0


if __name__ == "__main__":
    sys.exit(main())
