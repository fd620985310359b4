// Matrix-vector BLAS for the solver libraries' one-column products.
//
// MUMPS's solve phase updates each front with GEMM and TRSM on the
// right-hand side, one column wide when one system is solved. OpenBLAS before
// 0.3.27 (Debian 12 ships 0.3.21) packs both operands of every GEMM and TRSM
// into its block buffers, also then: a copy of the whole factor per solve, on
// top of the pass that multiplies (a PSH solve on the liver: 9.8 ms, 60 % of
// it in OpenBLAS's packing routines; 5.9 ms with the matrix-vector routines,
// the factor's two passes at 15 GB/s). This library defines dgemm_, dtrsm_,
// sgemm_ and strsm_ for the process: a product or triangular solve with one
// row or column goes to GEMV or TRSV, everything else to the BLAS the process
// loaded (found by dlsym(RTLD_NEXT)). The results are those of the same
// arithmetic in another order of summation. A process that links this library gets the definitions
// ahead of the shared BLAS library's (the dynamic linker binds a shared
// library's references to the executable's definitions first).
#pragma once

#include <cstdint>

namespace organsim::fem::detail {

/// Finds the loaded BLAS's routines (once per process). Throws
/// std::runtime_error when no BLAS is loaded. Called by the factorizations
/// that use BLAS, so that this file's definitions are linked in.
void route_single_column_blas();

/// One-column products and solves sent to GEMV and TRSV so far (for tests).
std::uint64_t single_column_blas_calls() noexcept;

}  // namespace organsim::fem::detail
