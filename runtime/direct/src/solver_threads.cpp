#include "solver_threads.h"

#include <dlfcn.h>

#include <mutex>

namespace organsim::fem::detail {

void use_one_solver_thread() {
  static std::once_flag once;
  std::call_once(once, [] {
    // Looked up at run time: Debian's BLAS is chosen by update-alternatives
    // (OpenBLAS exports this, the reference BLAS is one thread anyway), and
    // libgomp is there only when the solver libraries were built with OpenMP.
    using SetCount = void (*)(int);
    if (auto set = reinterpret_cast<SetCount>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) set(1);
    if (auto set = reinterpret_cast<SetCount>(dlsym(RTLD_DEFAULT, "omp_set_max_active_levels"))) set(0);
  });
}

}  // namespace organsim::fem::detail
