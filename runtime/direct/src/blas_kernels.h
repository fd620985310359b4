// OpenBLAS's kernels for the CPU the process runs on.
//
// OpenBLAS chooses its kernels for the CPU when the library is loaded, from
// the CPU's family and model. A CPU newer than the library gets its generic
// Prescott (SSE3) kernels: on the 2-vCPU Intel Xeon of model 207 (Emerald
// Rapids) with Debian 12's OpenBLAS 0.3.21, CHOLMOD's factorization of the
// co-rotational liver took 226 ms instead of 115 ms with the Skylake-X
// (AVX-512) kernels, MUMPS's of PSH 769 ms instead of 362 ms, and a PSH `poke`
// 18.1 s instead of 13.6 s. OpenBLAS reads the choice from OPENBLAS_CORETYPE
// at load time only, so the choice can be corrected only by starting the
// program again with the variable set.
//
// Part of the object library linked into organsim's own executables only
// (organsim_route_single_column_blas() in runtime/direct/CMakeLists.txt, which
// defines ORGANSIM_CHOOSES_BLAS_KERNELS for them); each calls it first thing
// in main().
#pragma once

namespace organsim::fem {

/// Where the loaded OpenBLAS fell back to its Prescott kernels on a CPU with
/// AVX-512 (or AVX2), sets OPENBLAS_CORETYPE to the matching kernels
/// (SkylakeX, Haswell) and executes this program again with the same
/// arguments (`argv` as main() received it); does not return then. Returns
/// at once where the user set OPENBLAS_CORETYPE (never overridden), where
/// OpenBLAS chose CPU-specific kernels, on an older CPU, or where the program
/// cannot be executed again (it goes on with the generic kernels). Call it
/// before anything else in main(): the program starts over.
void use_the_cpus_blas_kernels(char** argv) noexcept;

}  // namespace organsim::fem
