// One BLAS thread for the factorizations: the real-time loops own the cores
// (a second OpenBLAS thread spins while it waits and took the deformation
// loop's core: the co-rotational frame's p99 went from 60 to 140 ms), and a
// second thread gained only 10 % on the liver's PSH factorization.
#pragma once

namespace organsim::fem::detail {

/// Sets OpenBLAS (when it is the BLAS in use) to one thread, once per process.
void use_one_blas_thread();

}  // namespace organsim::fem::detail
