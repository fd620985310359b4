// One thread inside the solver libraries: the real-time loops and the tangent
// worker own the cores. Measured on the shipped liver (2 vCPU VM):
// - a second OpenBLAS thread spins while it waits and took the deformation
//   loop's core (co-rotational frame p99 60 → 140 ms), and gained only 10 % on
//   the PSH factorization;
// - Debian's CHOLMOD opens an OpenMP parallel region (4 threads, fixed in its
//   build) for every supernode: 32,000 thread wake-ups per factorization of the
//   co-rotational tangent, each crossing to the other virtual CPU, made it take
//   117 ms instead of 31 ms with the regions run by the calling thread alone.
#pragma once

namespace organsim::fem::detail {

/// Once per process: OpenBLAS (when it is the BLAS in use) to one thread, and
/// OpenMP parallel regions (libgomp, when a solver library loaded it) inactive
/// — max-active-levels 0, a process-wide setting: organsim runs no OpenMP code
/// of its own.
void use_one_solver_thread();

}  // namespace organsim::fem::detail
