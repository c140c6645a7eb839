#!/usr/bin/env python3
"""Scaling model of the distributed FFT cell (BENCHMARKS.md, "Distributed FFT cells").

Per Krylov iteration of the Newton-CG solver with the stencil operator on an n^3 cell over P slab ranks:
  compute  = t_voxel * n^3 / P                     (t_voxel measured on one rank, bench_fft_mpi)
  transfer = A * 48 B * m1 n^2 (n / P) (P - 1) / P + (3 + 9) * 8 B * n^2   per rank
             (A all-to-alls of the 3-field half spectrum, 16 B complex, m1 = n/2 + 1; halo planes)
  comm     = A * alpha * (P - 1) + transfer / beta
A = 4 for the spectrum in slab order (FFTW-MPI without TRANSPOSED_OUT: two transposes per transform,
one backward and one forward transform per iteration), A = 2 with a transposed spectrum.
Slabs need P <= n. Memory per rank: bytes_voxel * n^3 / P (solver arrays) + image_voxel * (n^3 / P + 2 n^2)
(the phase image as a rank holds it: its slab and one halo plane each side, rve/slab_image.hpp).

usage: fft_mpi_model.py [t_voxel_us] [alpha_us] [beta_GBps] [bytes_voxel] [image_voxel]
"""
import sys

t_voxel = float(sys.argv[1]) * 1e-6 if len(sys.argv) > 1 else 0.27e-6
alpha = float(sys.argv[2]) * 1e-6 if len(sys.argv) > 2 else 2e-6
beta = float(sys.argv[3]) * 1e9 if len(sys.argv) > 3 else 1e9
bytes_voxel = float(sys.argv[4]) if len(sys.argv) > 4 else 474.0
image_voxel = float(sys.argv[5]) if len(sys.argv) > 5 else 32.0

print("t_voxel %.3g us, alpha %.3g us, beta %.3g GB/s per rank" % (t_voxel * 1e6, alpha * 1e6, beta / 1e9))
print("| n³ | P | compute [ms] | MB sent/rank | comm [ms] (slab order) | efficiency | comm [ms] (transposed) | efficiency | memory/rank [GB] |")
print("|---|---|---|---|---|---|---|---|---|")
for n in (512, 1024):
    N = n ** 3
    m1 = n // 2 + 1
    for P in (64, 128, 256, 512, 1024):
        if P > n:
            print("| %d³ | %d | – | – | slabs need P ≤ n3 = %d (pencils) | | | | |" % (n, P, n))
            continue
        compute = t_voxel * N / P
        row = ["%d³" % n, str(P), "%.0f" % (1e3 * compute)]
        halo = 12 * 8 * n * n
        for A in (4, 2):
            transfer = A * 48 * m1 * n * (n / P) * (P - 1) / P + halo
            comm = A * alpha * (P - 1) + transfer / beta
            if A == 4:
                row.append("%.0f" % (transfer / 1e6))
            row += ["%.0f" % (1e3 * comm), "%.0f %%" % (100 * compute / (compute + comm))]
        row.append("%.2f" % ((bytes_voxel * N / P + image_voxel * (N / P + 2 * n * n)) / 1e9))
        print("| " + " | ".join(row) + " |")
