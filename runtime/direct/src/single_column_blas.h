// Matrix-vector BLAS for the solver libraries' one-column products.
//
// MUMPS's solve phase updates each front with GEMM and TRSM on the
// right-hand side, one column wide when one system is solved. OpenBLAS before
// 0.3.27 (Debian 12 ships 0.3.21) packs both operands of every GEMM and TRSM
// into its block buffers, also then: a copy of the whole factor per solve, on
// top of the pass that multiplies (a PSH solve on the liver: 9.8 ms, 60 % of
// it in OpenBLAS's packing routines; 5.9 ms with the matrix-vector routines,
// the factor's two passes at 15 GB/s). This file defines dgemm_, dtrsm_,
// sgemm_ and strsm_ for the process: a product or triangular solve with one
// row or column goes to GEMV or TRSV, everything else to the BLAS the process
// loaded (found by dlsym(RTLD_NEXT)). The results are those of the same
// arithmetic in another order of summation. An executable that contains it
// gets the definitions ahead of the shared BLAS library's (the dynamic linker
// binds a shared library's references to the executable's definitions first).
//
// Because the definitions apply to the whole process, the file is the object
// library organsim_single_column_blas, linked into organsim's own executables
// only (organsim_route_single_column_blas() in runtime/direct/CMakeLists.txt):
// no installed library and no Python module contains it, so a program that
// links organsim::fem_direct keeps its own BLAS untouched (docs/install.md).
#pragma once

#include <cstdint>

namespace organsim::fem::detail {

/// One-column products and solves sent to GEMV and TRSV so far (for tests).
std::uint64_t single_column_blas_calls() noexcept;

}  // namespace organsim::fem::detail
