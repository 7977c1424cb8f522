#!/usr/bin/env python3
"""Straightforward NumPy implementations of the radar hot steps, timed on the inputs that
`cargo run --release -p radar-sim --example bench` writes (same inputs, same sizes, median over
the same number of repetitions). Prints one JSON object on stdout.

Steps (each vectorised over the natural inner axis, a Python loop over pulses):
  synthesis       per pulse: every path's bistatic range, receive gain (same antenna pattern),
                  radar-equation amplitude, carrier phase and delay; in-CP paths summed as phase
                  ramps over the subcarriers and one IFFT; paths beyond the CP split into
                  per-symbol pieces, one IFFT each; thermal noise; complex64 output.
  cancellation    per pulse: ECA with the reference's cyclic shifts (taps) by least squares
                  (numpy.linalg.lstsq) and the canceller metrics the Rust processor reports
                  (powers, direct-path matched filter before/after, test-target loss by the same
                  projection), then the reciprocal range filter and the x U upsampled profile
                  by zero-padded IFFT, keeping the window that the image needs.
  backprojection  per pulse: f64 bistatic range of every pixel, linear interpolation of the
                  upsampled profile, carrier phase, accumulate.
Each output is also compared with Rust's (signal-to-error ratio, dB) to show equal work.
"""
import json
import os
import sys
import time

# One BLAS thread: on a shared 2-core machine a multi-threaded BLAS in lstsq spends its time
# waiting for cores (measured 20x slower under load); the figures are per thread anyway.
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import numpy as np  # noqa: E402

C = 299_792_458.0


def load_avg():
    try:
        return " ".join(open("/proc/loadavg").read().split()[:3])
    except OSError:
        return ""


def timed(reps, f):
    load = load_avg()
    walls, cpus, out = [], [], None
    for _ in range(reps):
        c0 = time.process_time()
        t0 = time.perf_counter()
        out = f()
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    timed.best = float(np.min(walls))
    return float(np.median(walls)), float(np.median(cpus)), load, out


def ser_db(a, ref):
    a = np.asarray(a, dtype=np.complex128).ravel()
    ref = np.asarray(ref, dtype=np.complex128).ravel()
    return float(10 * np.log10(np.sum(np.abs(ref) ** 2) / np.sum(np.abs(a - ref) ** 2)))


def sinc(x):
    return np.sinc(x)  # sin(pi x)/(pi x)


def gain(cfg, heading, u):
    """Receive power gain towards unit directions u (P x 3) for a heading (x, y)."""
    a = cfg["antenna"]
    lam = cfg["wavelength_m"]
    h = np.array([heading[0], heading[1], 0.0])
    r = np.array([heading[1], -heading[0], 0.0])
    s, c = np.sin(a["look_rad"]), np.cos(a["look_rad"])
    b = np.array([s * r[0], s * r[1], -c])
    e = np.cross(h, b)
    f = sinc(a["length_m"] * (u @ h) / lam) * sinc(a["height_m"] * (u @ e) / lam)
    g = a["peak_gain"] * np.maximum(f * f, a["floor"])
    return np.where(u @ b <= 0.0, a["peak_gain"] * a["back"], g)


def synthesize(cfg, pulses, objects, data_of, noise, rng):
    n, ncp, nsc = cfg["fft_size"], cfg["cp_samples"], cfg["subcarriers"]
    fs, lam, eirp = cfg["fs_hz"], cfg["wavelength_m"], cfg["eirp_w"]
    ns = n + ncp
    k = np.arange(nsc) - nsc // 2
    bins = k % n
    bs = np.array(cfg["bs_m"])
    q = np.column_stack([objects[:, 0], objects[:, 1], np.zeros(len(objects))])
    rt = np.linalg.norm(q - bs, axis=1)
    sigma = np.sqrt(cfg["noise_w"] / 2)
    out = np.empty((len(pulses), n), dtype=np.complex64)
    for i, (x, y, z, hx, hy, dly, sym) in enumerate(pulses):
        pos = np.array([x, y, z])
        dq = q - pos
        rr = np.linalg.norm(dq, axis=1)
        rd = np.linalg.norm(bs - pos)
        g_e = gain(cfg, (hx, hy), dq / rr[:, None])
        g_d = gain(cfg, (hx, hy), ((bs - pos) / rd)[None, :])[0]
        p_e = eirp * g_e * objects[:, 2] * lam**2 / ((4 * np.pi) ** 3 * rt**2 * rr**2)
        p_d = eirp * g_d * lam**2 / (4 * np.pi * rd) ** 2
        r = np.concatenate([[rd], rt + rr])
        p = np.concatenate([[p_d], p_e])
        ph = np.concatenate([[0.0], objects[:, 3]])
        cyc = r / lam
        amp = np.sqrt(p) * np.exp(-2j * np.pi * (cyc - np.floor(cyc))) * np.exp(1j * ph)
        delay = r * fs / C - dly
        acc = np.zeros(n, dtype=np.complex128)
        inside = (delay > -1.0) & (delay <= ncp)
        x_m = data_of(i, 0)
        if inside.any():
            s = (amp[inside, None] * np.exp(-2j * np.pi * np.outer(delay[inside], k) / n)).sum(axis=0)
            spec = np.zeros(n, dtype=np.complex128)
            spec[bins] = x_m * s / np.sqrt(nsc)
            acc += np.fft.ifft(spec) * n
        for a_p, d_p in zip(amp[~inside], delay[~inside]):
            j_first = int(np.floor((0 - d_p + ncp) / ns))
            j_last = int(np.floor((n - 1 - d_p + ncp) / ns))
            for j in range(j_first, j_last + 1):
                lo = int(max(np.ceil(d_p - ncp + j * ns), 0))
                hi = int(min(np.ceil(d_p - ncp + (j + 1) * ns), n))
                if lo >= hi or sym + j < 0:
                    continue
                dd = d_p + j * ns
                spec = np.zeros(n, dtype=np.complex128)
                spec[bins] = data_of(i, j) * np.exp(-2j * np.pi * k * dd / n) / np.sqrt(nsc)
                acc[lo:hi] += a_p * (np.fft.ifft(spec) * n)[lo:hi]
        if noise:
            acc += sigma * (rng.standard_normal(n) + 1j * rng.standard_normal(n))
        out[i] = acc
    return out


def bench_synthesis(cfg, d, tag, reps):
    pulses = np.load(f"{d}/{tag}_pulses.npy")
    objects = np.load(f"{d}/{tag}_objects.npy")
    data = np.load(f"{d}/{tag}_data.npy").astype(np.complex128)  # pulses x 4 (m-2..m+1) x nsc
    nsc = cfg["subcarriers"]
    rng = np.random.default_rng(1)

    def random_qpsk(i, j):
        return (rng.choice([-1.0, 1.0], nsc) + 1j * rng.choice([-1.0, 1.0], nsc)) / np.sqrt(2)

    w, c, load, _ = timed(reps, lambda: synthesize(cfg, pulses, objects, random_qpsk, True, rng))
    clean = synthesize(cfg, pulses, objects, lambda i, j: data[i, j + 2], False, rng)
    ref = np.load(f"{d}/{tag}_clean.npy")
    best = timed.best
    return {"wall_s": w, "cpu_s": c, "best_s": best, "load": load, "samples": float(pulses.shape[0] * cfg["fft_size"]),
            "ser_db": ser_db(clean, ref)}


def compress(cfg, iq, data, j0s, m, delays):
    """Per pulse, as the Rust processor: ECA (cyclic taps, least squares) with its metrics
    (input/output power, matched-filter output at the direct path's delay before and after, the
    power a unit test target at the landmark's delay keeps through the projection), then the
    reciprocal filter and the upsampled profile window."""
    n, nsc, up = cfg["fft_size"], cfg["subcarriers"], cfg["upsample"]
    k = np.arange(nsc) - nsc // 2
    bins = k % n
    taps = np.arange(-cfg["taps_before"], cfg["taps_after"])
    out = np.empty((iq.shape[0], m), dtype=np.complex64)
    nu = n * up
    met = dict(input_power=0.0, output_power=0.0, dp_mf_before=0.0, dp_mf_after=0.0,
               target_before=0.0, target_after=0.0)

    def mf(y, uk, d):
        return np.sum(np.conj(uk) * y[bins] * np.exp(2j * np.pi * k * d / n)) / np.sum(np.abs(uk) ** 2)

    for i in range(iq.shape[0]):
        r = iq[i].astype(np.complex128)
        x = data[i]
        uk = n * x / np.sqrt(nsc)
        spec = np.zeros(n, dtype=np.complex128)
        spec[bins] = x
        u = np.fft.ifft(spec) * n / np.sqrt(nsc)
        y = np.fft.fft(r)
        met["input_power"] += np.mean(np.abs(r) ** 2)
        met["dp_mf_before"] += np.abs(mf(y, uk, delays[i, 0])) ** 2
        basis = np.stack([np.roll(u, t) for t in taps], axis=1)
        wts, *_ = np.linalg.lstsq(basis, r, rcond=None)
        r = r - basis @ wts
        # unit test target at the landmark's delay through the same projection
        st = np.zeros(n, dtype=np.complex128)
        st[bins] = x * np.exp(-2j * np.pi * k * delays[i, 1] / n)
        s_t = np.fft.ifft(st) * n / np.sqrt(nsc)
        wt, *_ = np.linalg.lstsq(basis, s_t, rcond=None)
        met["target_before"] += np.vdot(s_t, s_t).real
        res = s_t - basis @ wt
        met["target_after"] += np.vdot(res, res).real
        y = np.fft.fft(r)
        met["output_power"] += np.mean(np.abs(r) ** 2)
        met["dp_mf_after"] += np.abs(mf(y, uk, delays[i, 0])) ** 2
        z = y[bins] * np.conj(x) / np.abs(x) ** 2 * np.sqrt(nsc) / (n * nsc)
        full = np.zeros(nu, dtype=np.complex128)
        full[k % nu] = z
        prof = np.fft.ifft(full) * nu
        out[i] = prof[(int(j0s[i]) + np.arange(m)) % nu]
    met["target_loss_db"] = float(-10 * np.log10(met["target_after"] / met["target_before"]))
    return out, met


def bench_compress(cfg, d, reps):
    iq = np.load(f"{d}/cancel_iq.npy")
    data = np.load(f"{d}/incp_data.npy")[:, 2, :].astype(np.complex128)
    j0s = np.load(f"{d}/cancel_j0.npy")
    delays = np.load(f"{d}/cancel_delays.npy")
    m = cfg["profile_m"]
    w, c, load, (prof, met) = timed(reps, lambda: compress(cfg, iq, data, j0s, m, delays))
    best = timed.best
    ref = np.load(f"{d}/cancel_profiles.npy")
    return {"wall_s": w, "cpu_s": c, "best_s": best, "load": load, "pulses": float(iq.shape[0]),
            "ser_db": ser_db(prof, ref), "metrics": {k: float(v) for k, v in met.items()}}


def backproject(cfg, prof, pulses):
    nx, ny, d = cfg["nx"], cfg["ny"], cfg["spacing_m"]
    cx, cy = cfg["centre_m"]
    bs = np.array(cfg["bs_m"])
    xs = cx + (np.arange(nx) - (nx - 1) / 2) * d
    ys = cy + (np.arange(ny) - (ny - 1) / 2) * d
    X, Y = np.meshgrid(xs, ys)
    rtx = np.sqrt((X - bs[0]) ** 2 + (Y - bs[1]) ** 2 + bs[2] ** 2)
    m = prof.shape[1]
    img = np.zeros((ny, nx), dtype=np.complex128)
    lam = cfg["wavelength_m"]
    for i in range(pulses.shape[0]):
        ux, uy, uz, dly, j0, w = pulses[i]
        r = rtx + np.sqrt((X - ux) ** 2 + (Y - uy) ** 2 + uz**2)
        x = np.clip((r * cfg["fs_hz"] / C - dly) * cfg["upsample"] - j0, 0, m - 2)
        i0 = np.floor(x).astype(np.int64)
        f = x - i0
        p = prof[i]
        v = p[i0] + f * (p[i0 + 1] - p[i0])
        cyc = r / lam
        img += w * v * np.exp(2j * np.pi * (cyc - np.floor(cyc)))
    return img


def bench_bp(cfg, d, reps):
    prof = np.load(f"{d}/bp_profiles.npy")
    pulses = np.load(f"{d}/bp_pulses.npy")
    w, c, load, img = timed(reps, lambda: backproject(cfg, prof, pulses))
    best = timed.best
    np.save(f"{d}/numpy_image.npy", img.astype(np.complex64))
    return {"wall_s": w, "cpu_s": c, "best_s": best, "load": load,
            "work": float(cfg["nx"] * cfg["ny"] * pulses.shape[0])}


def main():
    d = sys.argv[1]
    cfg = json.load(open(f"{d}/config.json"))
    reps = cfg["reps"]
    res = {"numpy": np.__version__, "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default")}
    for tag in ("incp", "split"):
        res[f"synth_{tag}"] = bench_synthesis(cfg, d, tag, reps)
    res["compress"] = bench_compress(cfg, d, reps)
    res["bp"] = bench_bp(cfg, d, reps)
    print(json.dumps(res))


if __name__ == "__main__":
    main()
