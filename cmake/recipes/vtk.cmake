# VTK 9.1 (Debian libvtk9-dev), only the modules we use: surface extraction in
# the pipeline (FiltersCore), mesh files (IOXML, IOGeometry), the viewer
# (Rendering*, InteractionStyle, FiltersSources) and the line plots
# (ChartsCore, ViewsContext2D, RenderingContextOpenGL2; PNG through IOImage) and
# field views (FiltersGeometry for a mesh's boundary, RenderingAnnotation for the
# colour bar).
find_package(VTK 9.1 REQUIRED COMPONENTS
  CommonCore CommonDataModel FiltersCore FiltersSources IOXML IOGeometry
  RenderingCore RenderingOpenGL2 RenderingFreeType InteractionStyle
  ChartsCore ViewsContext2D RenderingContext2D RenderingContextOpenGL2 IOImage
  FiltersGeometry RenderingAnnotation)
