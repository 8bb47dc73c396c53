#include <prt/ply.h>

#include <prt/error.h>
#include <prt/io.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace prt {

void write_ply(const std::string& path, const Mesh& mesh, const std::vector<glm::vec3>& colors, PlyColors format,
               const std::string& comment) {
  const bool bytes = format == PlyColors::Bytes, colored = !colors.empty();
  PRT_CHECK(!colored || colors.size() == mesh.vertex_count());
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error(path + ": cannot open for writing");
    const char* type = bytes ? "uchar" : "float";
    f << "ply\nformat binary_little_endian 1.0\ncomment " << comment << "\n"
      << "element vertex " << mesh.vertex_count() << "\n"
      << "property float x\nproperty float y\nproperty float z\n"
      << "property float nx\nproperty float ny\nproperty float nz\n";
    if (colored) f << "property " << type << " red\nproperty " << type << " green\nproperty " << type << " blue\n";
    f << "element face " << mesh.triangles.size() << "\n"
      << "property list uchar int vertex_indices\nend_header\n";
    std::vector<float> v(9);
    for (std::size_t i = 0; i < mesh.vertex_count(); ++i) {
      const glm::vec3 p = mesh.positions[i], nrm = mesh.normals[i], c = colored ? colors[i] : glm::vec3(0.0f);
      const float rec[9] = {p.x, p.y, p.z, nrm.x, nrm.y, nrm.z, c.x, c.y, c.z};
      if (!colored) {
        f.write(reinterpret_cast<const char*>(rec), 6 * sizeof(float));
      } else if (bytes) {
        unsigned char rgb[3];
        for (int k = 0; k < 3; ++k) rgb[k] = static_cast<unsigned char>(std::lround(std::clamp(c[k], 0.0f, 1.0f) * 255.0f));
        f.write(reinterpret_cast<const char*>(rec), 6 * sizeof(float));
        f.write(reinterpret_cast<const char*>(rgb), sizeof rgb);
      } else {
        f.write(reinterpret_cast<const char*>(rec), sizeof rec);
      }
    }
    for (const glm::uvec3& t : mesh.triangles) {
      const unsigned char three = 3;
      const std::int32_t idx[3] = {std::int32_t(t.x), std::int32_t(t.y), std::int32_t(t.z)};
      f.write(reinterpret_cast<const char*>(&three), 1);
      f.write(reinterpret_cast<const char*>(idx), sizeof idx);
    }
    f.close();
    if (!f) throw Error(path + ": write failed");
  });
}

}  // namespace prt
