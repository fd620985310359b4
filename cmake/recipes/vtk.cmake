# VTK 9.1 (Debian libvtk9-dev), only the modules we use: surface extraction in
# the pipeline (FiltersCore), mesh files (IOXML, IOGeometry) and the viewer
# (Rendering*, InteractionStyle, FiltersSources).
find_package(VTK 9.1 REQUIRED COMPONENTS
  CommonCore CommonDataModel FiltersCore FiltersSources IOXML IOGeometry
  RenderingCore RenderingOpenGL2 RenderingFreeType InteractionStyle)
