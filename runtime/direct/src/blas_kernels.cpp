// OpenBLAS's kernels for the CPU the process runs on.
//
// OpenBLAS chooses its kernels for the CPU when the library is loaded, from
// the CPU's family and model. A CPU newer than the library gets its generic
// Prescott (SSE3) kernels: on the 2-vCPU Intel Xeon of model 207 (Emerald
// Rapids) with Debian 12's OpenBLAS 0.3.21, CHOLMOD's factorization of the
// co-rotational liver took 226 ms instead of 115 ms with the Skylake-X
// (AVX-512) kernels, MUMPS's of PSH 769 ms instead of 362 ms, and a PSH `poke`
// 18.1 s instead of 13.6 s. OpenBLAS reads the choice from OPENBLAS_CORETYPE
// at load time only, so before main() this file asks the loaded library which
// kernels it chose; where it fell back to Prescott on a CPU with AVX-512 (or
// AVX2), it sets the variable to the matching kernels and executes the same
// program again with the same arguments (once: the variable is then set, and
// a variable the user set is never overridden). It is part of the object
// library linked into organsim's own executables only (single_column_blas.h).
#include <dlfcn.h>
#include <strings.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace {

/// The program's arguments, as /proc gives them (before main, argv is not ours).
std::vector<std::string> own_arguments() {
  std::vector<std::string> arguments;
  std::ifstream file("/proc/self/cmdline", std::ios::binary);
  std::string argument;
  while (std::getline(file, argument, '\0')) arguments.push_back(argument);
  return arguments;
}

void use_the_cpus_kernels() {
  if (std::getenv("OPENBLAS_CORETYPE")) return;
  using CoreName = char* (*)();
  const auto core_name = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (!core_name || !core_name() || strcasecmp(core_name(), "prescott") != 0) return;
  __builtin_cpu_init();
  const char* kernels = __builtin_cpu_supports("avx512f") ? "SkylakeX" : __builtin_cpu_supports("avx2") ? "Haswell" : nullptr;
  if (!kernels) return;  // a CPU that old gets what it is
  std::vector<std::string> arguments = own_arguments();
  if (arguments.empty()) return;
  std::vector<char*> argv;
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  setenv("OPENBLAS_CORETYPE", kernels, 1);
  execv("/proc/self/exe", argv.data());
  unsetenv("OPENBLAS_CORETYPE");  // not executed again: go on with the generic kernels
}

const bool kChosen = (use_the_cpus_kernels(), true);

}  // namespace
