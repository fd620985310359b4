// See blas_kernels.h for why a program may start over with OPENBLAS_CORETYPE set.
#include "blas_kernels.h"

#include <dlfcn.h>
#include <strings.h>
#include <unistd.h>

#include <cstdlib>

namespace organsim::fem {

void use_the_cpus_blas_kernels(char** argv) noexcept {
  if (argv == nullptr || argv[0] == nullptr || std::getenv("OPENBLAS_CORETYPE")) return;
  using CoreName = char* (*)();
  const auto core_name = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (!core_name || !core_name() || strcasecmp(core_name(), "prescott") != 0) return;
  __builtin_cpu_init();
  const char* kernels = __builtin_cpu_supports("avx512f") ? "SkylakeX"
                        : __builtin_cpu_supports("avx2")  ? "Haswell"
                                                          : nullptr;
  if (!kernels) return;  // a CPU that old gets what it is
  setenv("OPENBLAS_CORETYPE", kernels, 1);
  execv("/proc/self/exe", argv);
  unsetenv("OPENBLAS_CORETYPE");  // not executed again: go on with the generic kernels
}

}  // namespace organsim::fem
