#include "blas_threads.h"

#include <dlfcn.h>

#include <mutex>

namespace organsim::fem::detail {

void use_one_blas_thread() {
  static std::once_flag once;
  std::call_once(once, [] {
    // Debian's BLAS is chosen by update-alternatives: OpenBLAS exports this,
    // the reference BLAS (one thread anyway) does not.
    using SetThreads = void (*)(int);
    if (auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) set(1);
  });
}

}  // namespace organsim::fem::detail
