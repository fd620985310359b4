# Eigen 3.4 (Debian libeigen3-dev): all linear algebra; the runtime's only heavy dependency.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
