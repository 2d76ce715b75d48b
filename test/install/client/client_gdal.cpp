// A downstream project of the GDAL layer: a 4 x 3 GeoTIFF written through the installed headers and
// pcl_delaunay_walk::gdal, then checked to be a TIFF (its byte-order mark and magic number).
#include <pcl_delaunay_walk/core/dem/raster_grid.h>
#include <pcl_delaunay_walk/gdal/geotiff_writer.h>

#include <cstdio>
#include <exception>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  try {
    const dw::dem::RasterGrid grid = dw::dem::gridFromBounds(500000, 6000000, 500004, 6000003, 1.0);
    std::vector<double> cells(grid.size());
    for (std::size_t i = 0; i < cells.size(); ++i) cells[i] = i == 5 ? -9999 : 100.0 + 0.5 * double(i);
    dw::gdal::GeoTiffOptions o;
    o.num_threads = 1;
    dw::gdal::GeoTiffWriter w(argv[1], grid, o);
    w.writeRows(0, grid.rows, cells.data());
    w.commit();
    unsigned char head[4] = {0, 0, 0, 0};
    std::FILE* f = std::fopen(argv[1], "rb");
    const bool read = f && std::fread(head, 1, 4, f) == 4;
    if (f) std::fclose(f);
    const bool tiff = read && ((head[0] == 'I' && head[1] == 'I' && head[2] == 42 && head[3] == 0) ||
                               (head[0] == 'M' && head[1] == 'M' && head[2] == 0 && head[3] == 42));
    std::printf("client_gdal: %zu x %zu GeoTIFF %s: %s\n", grid.cols, grid.rows, argv[1],
                tiff ? "a TIFF" : "not a TIFF");
    return tiff ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "client_gdal: %s\n", e.what());
    return 1;
  }
}
