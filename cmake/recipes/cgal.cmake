# CGAL 5.5 (Debian libcgal-dev; GPL): Mesh_3 tetrahedralization only. Linked by
# the tetrahedra stage's own target and nothing else, so that no other library
# of ours depends on it (as libigl keeps its copyleft code apart).
find_package(CGAL 5.5 REQUIRED)
