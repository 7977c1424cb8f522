#!/usr/bin/env python3
"""Straightforward NumPy implementations of the radar hot steps, timed on the inputs that
`cargo run --release -p radar-sim --example bench` writes (same sizes, same backprojection
inputs). Prints one JSON object on stdout.

Steps:
  backprojection  for each pulse: f64 bistatic range of every pixel (vectorised over pixels),
                  linear interpolation of the upsampled profile, carrier phase, accumulate
  synthesis       per pulse: phase ramp of every path over the subcarriers, sum, one IFFT, noise
  cancellation    per pulse: ECA with K cyclic taps by least squares (numpy.linalg.lstsq)
"""
import json
import sys
import time

import numpy as np

C = 299_792_458.0


def backproject(cfg, prof, pulses, max_pulses):
    nx, ny, d = cfg["nx"], cfg["ny"], cfg["spacing_m"]
    cx, cy = cfg["centre_m"]
    bs = np.array(cfg["bs_m"])
    xs = cx + (np.arange(nx) - (nx - 1) / 2) * d
    ys = cy + (np.arange(ny) - (ny - 1) / 2) * d
    X, Y = np.meshgrid(xs, ys)
    rtx = np.sqrt((X - bs[0]) ** 2 + (Y - bs[1]) ** 2 + bs[2] ** 2)
    m = prof.shape[1]
    img = np.zeros((ny, nx), dtype=np.complex128)
    k = cfg["fs_hz"] / C * cfg["upsample"]
    lam = cfg["wavelength_m"]
    n = min(max_pulses, pulses.shape[0])
    t0 = time.perf_counter()
    for i in range(n):
        ux, uy, uz, dly, j0, w = pulses[i]
        r = rtx + np.sqrt((X - ux) ** 2 + (Y - uy) ** 2 + uz ** 2)
        x = np.clip((r * cfg["fs_hz"] / C - dly) * cfg["upsample"] - j0, 0, m - 2)
        i0 = np.floor(x).astype(np.int64)
        f = x - i0
        p = prof[i]
        v = p[i0] + f * (p[i0 + 1] - p[i0])
        img += w * v * np.exp(2j * np.pi * (r / lam))
    dt = time.perf_counter() - t0
    return img, n * nx * ny / dt, dt, n


def synthesis(nsc, nfft, paths, pulses, rng):
    k = np.arange(nsc) - nsc // 2
    bins = k % nfft
    t0 = time.perf_counter()
    for _ in range(pulses):
        x = (rng.choice([-1.0, 1.0], nsc) + 1j * rng.choice([-1.0, 1.0], nsc)) / np.sqrt(2)
        delays = rng.uniform(0, 1000, paths)
        amps = rng.normal(size=paths) + 1j * rng.normal(size=paths)
        acc = (amps[:, None] * np.exp(-2j * np.pi * np.outer(delays, k) / nfft)).sum(axis=0)
        spec = np.zeros(nfft, dtype=np.complex128)
        spec[bins] = x * acc / np.sqrt(nsc)
        y = np.fft.ifft(spec) * nfft
        y += (rng.normal(size=nfft) + 1j * rng.normal(size=nfft)) * 0.1
    dt = time.perf_counter() - t0
    return pulses * nfft / dt, dt


def cancellation(nsc, nfft, taps, pulses, rng):
    k = np.arange(nsc) - nsc // 2
    bins = k % nfft
    t0 = time.perf_counter()
    for _ in range(pulses):
        x = (rng.choice([-1.0, 1.0], nsc) + 1j * rng.choice([-1.0, 1.0], nsc)) / np.sqrt(2)
        spec = np.zeros(nfft, dtype=np.complex128)
        spec[bins] = x
        u = np.fft.ifft(spec)
        r = 1000 * np.roll(u, 1) + (rng.normal(size=nfft) + 1j * rng.normal(size=nfft))
        B = np.stack([np.roll(u, t) for t in range(-4, taps - 4)], axis=1)
        w, *_ = np.linalg.lstsq(B, r, rcond=None)
        r = r - B @ w
    dt = time.perf_counter() - t0
    return dt / pulses, dt


def main():
    d = sys.argv[1]
    cfg = json.load(open(f"{d}/bp.json"))
    prof = np.load(f"{d}/profiles.npy")
    pulses = np.load(f"{d}/pulses.npy")
    img, rate, dt, n = backproject(cfg, prof, pulses, cfg["numpy_pulses"])
    np.save(f"{d}/numpy_image.npy", img.astype(np.complex64))
    rng = np.random.default_rng(1)
    s_rate, s_dt = synthesis(cfg["subcarriers"], cfg["fft_size"], cfg["paths"], cfg["numpy_synth_pulses"], rng)
    c_per, c_dt = cancellation(cfg["subcarriers"], cfg["fft_size"], cfg["taps"], cfg["numpy_cancel_pulses"], rng)
    print(json.dumps({
        "numpy": np.__version__,
        "bp_pixel_pulses_per_s": rate, "bp_pulses": n, "bp_seconds": dt,
        "synth_samples_per_s": s_rate, "synth_seconds": s_dt,
        "cancel_seconds_per_pulse": c_per, "cancel_seconds": c_dt,
    }))


if __name__ == "__main__":
    main()
