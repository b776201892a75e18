// Reads a surface through the installed library: prints its vertex and face counts.
#include "shapemap/io.h"
#include "shapemap/mesh.h"

#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const shapemap::TriMesh m = shapemap::read_surface(argv[1]);
  std::cout << m.V.rows() << " " << m.F.rows() << "\n";
  return 0;
}
