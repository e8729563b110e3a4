#include "probe_sim/object_mesh.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>

namespace probe_sim {

// ================================================================ TriangleMesh

Eigen::AlignedBox3d TriangleMesh::boundingBox() const {
  Eigen::AlignedBox3d box;
  for (const auto& v : vertices) box.extend(v);
  return box;
}

Eigen::Vector3d TriangleMesh::triangleNormal(std::size_t triangle_index) const {
  const Eigen::Vector3i& t = triangles.at(triangle_index);
  const Eigen::Vector3d cross =
      (vertices[t[1]] - vertices[t[0]]).cross(vertices[t[2]] - vertices[t[0]]);
  const double norm = cross.norm();
  return norm > 0.0 ? Eigen::Vector3d(cross / norm) : Eigen::Vector3d::Zero();
}

void TriangleMesh::transform(const Eigen::Isometry3d& pose) {
  for (auto& v : vertices) v = pose * v;
}

void TriangleMesh::scale(double factor) {
  for (auto& v : vertices) v *= factor;
}

void TriangleMesh::append(const TriangleMesh& other) {
  const int offset = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (const auto& t : other.triangles) triangles.emplace_back(t.array() + offset);
}

// ================================================================ loaders

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("mesh file '" + path + "': " + what);
}

std::string readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open (") + std::strerror(errno) + ")");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.empty()) fail(path, "file is empty");
  return bytes;
}

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

// Shared final checks, so that every format reports unusable content the same way.
void validateLoaded(const std::string& path, const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) fail(path, "contains no triangles");
  for (const auto& v : mesh.vertices) {
    if (!v.allFinite()) fail(path, "contains a non-finite vertex coordinate");
  }
  const int vertex_count = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles) {
    if ((t.array() < 0).any() || (t.array() >= vertex_count).any()) {
      fail(path, "a face refers to a vertex that does not exist");
    }
  }
}

template <typename T>
T readLittleEndian(const char* bytes) {
  // The formats are little-endian and so is every machine this runs on; memcpy avoids
  // unaligned access.
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

TriangleMesh parseBinaryStl(const std::string& path, const std::string& bytes) {
  constexpr std::size_t kHeaderBytes = 84;
  constexpr std::size_t kFacetBytes = 50;
  const auto facet_count = readLittleEndian<std::uint32_t>(bytes.data() + 80);
  const std::size_t expected = kHeaderBytes + kFacetBytes * static_cast<std::size_t>(facet_count);
  if (bytes.size() != expected) {
    fail(path, "binary STL header announces " + std::to_string(facet_count) + " triangles (" +
                   std::to_string(expected) + " bytes) but the file has " +
                   std::to_string(bytes.size()) + " bytes: truncated or corrupt");
  }
  TriangleMesh mesh;
  mesh.vertices.reserve(3 * facet_count);
  mesh.triangles.reserve(facet_count);
  for (std::uint32_t f = 0; f < facet_count; ++f) {
    const char* facet = bytes.data() + kHeaderBytes + kFacetBytes * f;
    const int first = static_cast<int>(mesh.vertices.size());
    for (int corner = 0; corner < 3; ++corner) {
      const char* xyz = facet + 12 + 12 * corner;  // the stored facet normal is not trusted
      mesh.vertices.emplace_back(readLittleEndian<float>(xyz), readLittleEndian<float>(xyz + 4),
                                 readLittleEndian<float>(xyz + 8));
    }
    mesh.triangles.emplace_back(first, first + 1, first + 2);
  }
  return mesh;
}

TriangleMesh parseAsciiStl(const std::string& path, const std::string& bytes) {
  std::istringstream in(bytes);
  TriangleMesh mesh;
  std::string token;
  while (in >> token) {
    if (token != "vertex") continue;
    Eigen::Vector3d v;
    if (!(in >> v.x() >> v.y() >> v.z())) {
      fail(path, "ASCII STL: 'vertex' not followed by three numbers (vertex " +
                     std::to_string(mesh.vertices.size()) + ")");
    }
    mesh.vertices.push_back(v);
  }
  if (mesh.vertices.size() % 3 != 0) {
    fail(path, "ASCII STL: vertex count " + std::to_string(mesh.vertices.size()) +
                   " is not a multiple of 3: truncated");
  }
  for (int i = 0; i + 2 < static_cast<int>(mesh.vertices.size()); i += 3) {
    mesh.triangles.emplace_back(i, i + 1, i + 2);
  }
  return mesh;
}

// ---------------------------------------------------------------- PLY

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
  PlyType value_type = PlyType::kFloat32;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

std::optional<PlyType> parsePlyType(const std::string& name) {
  if (name == "char" || name == "int8") return PlyType::kInt8;
  if (name == "uchar" || name == "uint8") return PlyType::kUint8;
  if (name == "short" || name == "int16") return PlyType::kInt16;
  if (name == "ushort" || name == "uint16") return PlyType::kUint16;
  if (name == "int" || name == "int32") return PlyType::kInt32;
  if (name == "uint" || name == "uint32") return PlyType::kUint32;
  if (name == "float" || name == "float32") return PlyType::kFloat32;
  if (name == "double" || name == "float64") return PlyType::kFloat64;
  return std::nullopt;
}

std::size_t plyTypeSize(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

// Reads PLY values either from whitespace-separated text or from packed little-endian bytes,
// with bounds checks so that a truncated body is reported instead of read past.
class PlyValueReader {
 public:
  PlyValueReader(const std::string& path, const std::string& bytes, std::size_t body_offset,
                 bool binary)
      : path_(path), bytes_(bytes), offset_(body_offset), binary_(binary) {
    if (!binary_) text_.str(bytes_.substr(body_offset));
  }

  double read(PlyType type) {
    if (!binary_) {
      double value;
      if (!(text_ >> value)) fail(path_, "PLY body ends early or holds a non-number");
      return value;
    }
    const std::size_t size = plyTypeSize(type);
    if (offset_ + size > bytes_.size()) fail(path_, "binary PLY body is truncated");
    const char* p = bytes_.data() + offset_;
    offset_ += size;
    switch (type) {
      case PlyType::kInt8:
        return readLittleEndian<std::int8_t>(p);
      case PlyType::kUint8:
        return readLittleEndian<std::uint8_t>(p);
      case PlyType::kInt16:
        return readLittleEndian<std::int16_t>(p);
      case PlyType::kUint16:
        return readLittleEndian<std::uint16_t>(p);
      case PlyType::kInt32:
        return readLittleEndian<std::int32_t>(p);
      case PlyType::kUint32:
        return readLittleEndian<std::uint32_t>(p);
      case PlyType::kFloat32:
        return readLittleEndian<float>(p);
      case PlyType::kFloat64:
        return readLittleEndian<double>(p);
    }
    return 0.0;
  }

 private:
  const std::string& path_;
  const std::string& bytes_;
  std::size_t offset_;
  bool binary_;
  std::istringstream text_;
};

TriangleMesh parsePly(const std::string& path, const std::string& bytes) {
  const std::size_t header_end = bytes.find("end_header");
  if (bytes.compare(0, 3, "ply") != 0 || header_end == std::string::npos) {
    fail(path, "not a PLY file (missing 'ply' magic or 'end_header')");
  }
  std::size_t body_offset = bytes.find('\n', header_end);
  if (body_offset == std::string::npos) fail(path, "PLY header is not terminated by a newline");
  ++body_offset;

  std::istringstream header(bytes.substr(0, header_end));
  std::string line;
  std::string format;
  std::vector<PlyElement> elements;
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      words >> format;
    } else if (keyword == "element") {
      PlyElement element;
      if (!(words >> element.name >> element.count)) fail(path, "bad PLY line '" + line + "'");
      elements.push_back(element);
    } else if (keyword == "property") {
      if (elements.empty()) fail(path, "PLY property before any element");
      PlyProperty property;
      std::string first;
      words >> first;
      if (first == "list") {
        std::string count_type, value_type;
        words >> count_type >> value_type >> property.name;
        const auto ct = parsePlyType(count_type);
        const auto vt = parsePlyType(value_type);
        if (!ct || !vt) fail(path, "unknown PLY type in '" + line + "'");
        property.is_list = true;
        property.count_type = *ct;
        property.value_type = *vt;
      } else {
        const auto type = parsePlyType(first);
        if (!type) fail(path, "unknown PLY type in '" + line + "'");
        property.value_type = *type;
        words >> property.name;
      }
      elements.back().properties.push_back(property);
    }
  }
  const bool binary = format == "binary_little_endian";
  if (!binary && format != "ascii") {
    fail(path, "unsupported PLY format '" + format + "' (ascii or binary_little_endian only)");
  }

  for (const PlyElement& element : elements) {
    // Every element with properties takes at least one byte, so a larger count is a corrupt
    // header (and would otherwise make the reservation below fail).
    if (!element.properties.empty() && element.count > bytes.size() - body_offset) {
      fail(path, "PLY element '" + element.name + "' announces " + std::to_string(element.count) +
                     " entries, more than the file can hold: truncated or corrupt");
    }
  }
  TriangleMesh mesh;
  PlyValueReader reader(path, bytes, body_offset, binary);
  for (const PlyElement& element : elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    if (is_vertex) mesh.vertices.reserve(element.count);
    for (std::size_t i = 0; i < element.count; ++i) {
      Eigen::Vector3d position = Eigen::Vector3d::Zero();
      for (const PlyProperty& property : element.properties) {
        if (!property.is_list) {
          const double value = reader.read(property.value_type);
          if (is_vertex && property.name == "x") position.x() = value;
          if (is_vertex && property.name == "y") position.y() = value;
          if (is_vertex && property.name == "z") position.z() = value;
          continue;
        }
        const double count_value = reader.read(property.count_type);
        if (count_value < 0 || count_value > 1e6) fail(path, "PLY list with a bad length");
        const auto count = static_cast<std::size_t>(count_value);
        std::vector<int> indices(count);
        for (std::size_t k = 0; k < count; ++k) {
          indices[k] = static_cast<int>(reader.read(property.value_type));
        }
        const bool is_index_list =
            property.name == "vertex_indices" || property.name == "vertex_index";
        if (is_face && is_index_list) {
          for (std::size_t k = 1; k + 1 < count; ++k) {
            mesh.triangles.emplace_back(indices[0], indices[k], indices[k + 1]);
          }
        }
      }
      if (is_vertex) mesh.vertices.push_back(position);
    }
  }
  return mesh;
}

// ---------------------------------------------------------------- OBJ

TriangleMesh parseObj(const std::string& path, const std::string& bytes) {
  std::istringstream in(bytes);
  TriangleMesh mesh;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "v") {
      Eigen::Vector3d v;
      if (!(words >> v.x() >> v.y() >> v.z())) {
        fail(path, "OBJ line " + std::to_string(line_number) + ": 'v' needs three numbers");
      }
      mesh.vertices.push_back(v);
    } else if (keyword == "f") {
      std::vector<int> polygon;
      std::string corner;
      while (words >> corner) {
        // "i", "i/t", "i//n" or "i/t/n": only the position index matters here.
        int index = 0;
        try {
          index = std::stoi(corner.substr(0, corner.find('/')));
        } catch (const std::exception&) {
          fail(path, "OBJ line " + std::to_string(line_number) + ": bad face index '" + corner +
                         "'");
        }
        // Negative indices count back from the latest vertex; positive ones are 1-based.
        polygon.push_back(index < 0 ? static_cast<int>(mesh.vertices.size()) + index
                                    : index - 1);
      }
      if (polygon.size() < 3) {
        fail(path, "OBJ line " + std::to_string(line_number) + ": face with fewer than 3 corners");
      }
      for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
        mesh.triangles.emplace_back(polygon[0], polygon[k], polygon[k + 1]);
      }
    }
  }
  return mesh;
}

std::string extensionOf(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const std::size_t slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return lowercase(path.substr(dot + 1));
}

}  // namespace

TriangleMesh loadStl(const std::string& path) {
  const std::string bytes = readWholeFile(path);
  TriangleMesh mesh;
  // Many binary STLs also start with "solid", so the size rule decides first: a binary file is
  // exactly 84 + 50 * n bytes.
  bool binary_size_matches = false;
  if (bytes.size() >= 84) {
    const auto n = readLittleEndian<std::uint32_t>(bytes.data() + 80);
    binary_size_matches = bytes.size() == 84 + 50 * static_cast<std::size_t>(n);
  }
  const bool looks_ascii = bytes.compare(0, 5, "solid") == 0 &&
                           bytes.find("facet") != std::string::npos;
  if (binary_size_matches || !looks_ascii) {
    if (bytes.size() < 84) {
      fail(path, "only " + std::to_string(bytes.size()) +
                     " bytes: shorter than a binary STL header (84 bytes) and not ASCII STL");
    }
    mesh = parseBinaryStl(path, bytes);
  } else {
    mesh = parseAsciiStl(path, bytes);
  }
  validateLoaded(path, mesh);
  return mesh;
}

TriangleMesh loadPly(const std::string& path) {
  TriangleMesh mesh = parsePly(path, readWholeFile(path));
  validateLoaded(path, mesh);
  return mesh;
}

TriangleMesh loadObj(const std::string& path) {
  TriangleMesh mesh = parseObj(path, readWholeFile(path));
  validateLoaded(path, mesh);
  return mesh;
}

TriangleMesh loadMesh(const std::string& path, double scale, const Eigen::Isometry3d& pose) {
  if (!std::isfinite(scale) || scale <= 0.0) {
    fail(path, "scale must be finite and > 0, got " + std::to_string(scale));
  }
  if (!pose.matrix().allFinite()) fail(path, "pose contains non-finite values");
  const std::string extension = extensionOf(path);
  TriangleMesh mesh;
  if (extension == "stl") {
    mesh = loadStl(path);
  } else if (extension == "ply") {
    mesh = loadPly(path);
  } else if (extension == "obj") {
    mesh = loadObj(path);
  } else {
    fail(path, "unknown mesh extension '" + extension + "' (expected stl, ply or obj)");
  }
  mesh.scale(scale);
  mesh.transform(pose);
  return mesh;
}

void placeOnTable(TriangleMesh& mesh, const Eigen::Vector2d& xy) {
  if (mesh.vertices.empty()) return;
  const Eigen::AlignedBox3d box = mesh.boundingBox();
  const Eigen::Vector3d shift(xy.x() - box.center().x(), xy.y() - box.center().y(), -box.min().z());
  for (auto& v : mesh.vertices) v += shift;
}

void saveStl(const TriangleMesh& mesh, const std::string& path) {
  std::ofstream out(path, std::ios::binary);
  if (!out) {
    throw std::runtime_error("cannot write STL file '" + path + "': " + std::strerror(errno));
  }
  char header[80] = {};
  std::snprintf(header, sizeof(header), "probe_sim binary STL");
  out.write(header, sizeof(header));
  const auto count = static_cast<std::uint32_t>(mesh.triangles.size());
  out.write(reinterpret_cast<const char*>(&count), sizeof(count));
  auto writeVector = [&out](const Eigen::Vector3d& v) {
    const float xyz[3] = {static_cast<float>(v.x()), static_cast<float>(v.y()),
                          static_cast<float>(v.z())};
    out.write(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  };
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    writeVector(mesh.triangleNormal(i));
    for (int corner = 0; corner < 3; ++corner) writeVector(mesh.vertices[mesh.triangles[i][corner]]);
    const std::uint16_t attribute = 0;
    out.write(reinterpret_cast<const char*>(&attribute), sizeof(attribute));
  }
  if (!out) throw std::runtime_error("error while writing STL file '" + path + "'");
}

// ================================================================ procedural objects

namespace {

constexpr double kPi = 3.14159265358979323846;

using Profile = std::vector<Eigen::Vector2d>;  // (radius, height) points

// Surface of revolution of a profile about the z axis. The profile is walked counter-clockwise
// in the (r, z) plane so that the winding gives outward normals; points on the axis (r = 0)
// become a single pole vertex.
TriangleMesh revolve(const Profile& profile, bool closed, int segments) {
  TriangleMesh mesh;
  std::vector<std::vector<int>> rings;
  for (const auto& rz : profile) {
    std::vector<int> ring;
    if (rz.x() <= 1e-12) {
      ring.assign(segments, static_cast<int>(mesh.vertices.size()));
      mesh.vertices.emplace_back(0.0, 0.0, rz.y());
    } else {
      for (int k = 0; k < segments; ++k) {
        const double angle = 2.0 * kPi * k / segments;
        ring.push_back(static_cast<int>(mesh.vertices.size()));
        mesh.vertices.emplace_back(rz.x() * std::cos(angle), rz.x() * std::sin(angle), rz.y());
      }
    }
    rings.push_back(ring);
  }
  const std::size_t edge_count = closed ? profile.size() : profile.size() - 1;
  for (std::size_t i = 0; i < edge_count; ++i) {
    const std::vector<int>& lower = rings[i];
    const std::vector<int>& upper = rings[(i + 1) % profile.size()];
    for (int k = 0; k < segments; ++k) {
      const int next = (k + 1) % segments;
      // Skip the degenerate half of each quad that touches a pole.
      if (lower[k] != lower[next]) mesh.triangles.emplace_back(lower[k], lower[next], upper[next]);
      if (upper[k] != upper[next]) mesh.triangles.emplace_back(lower[k], upper[next], upper[k]);
    }
  }
  return mesh;
}

// Arc of the circle centred at (centre_r, centre_z), from angle a0 to a1 (radians, measured
// from +r towards +z), with n + 1 points including both ends.
void appendArc(Profile& profile, const Eigen::Vector2d& centre, double radius, double a0,
               double a1, int n) {
  for (int i = 0; i <= n; ++i) {
    const double a = a0 + (a1 - a0) * i / n;
    profile.emplace_back(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a));
  }
}

// Cube projected onto the sphere with equal-angle spacing: near-uniform facets and no poles
// (a latitude-longitude sphere has sliver triangles at its poles whose normals are far off).
// cells_per_face_side cells span 90 degrees; an even count keeps vertices at the six extremes.
TriangleMesh makeSphereMesh(double radius, int cells_per_face_side) {
  const int n = cells_per_face_side;
  // One table for all faces, exactly symmetric, so that vertices on shared cube edges come out
  // bit-identical from both faces and leave no cracks.
  std::vector<double> tangent(n + 1);
  for (int i = 0; i <= n; ++i) tangent[i] = std::tan(kPi / 4 * (2.0 * i / n - 1.0));
  for (int i = 0; i <= n / 2; ++i) tangent[n - i] = -tangent[i];
  tangent[0] = -1.0;
  tangent[n] = 1.0;
  tangent[n / 2] = 0.0;
  TriangleMesh mesh;
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      const int u = (axis + 1) % 3;
      const int v = (axis + 2) % 3;
      const int first = static_cast<int>(mesh.vertices.size());
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= n; ++j) {
          Eigen::Vector3d p;
          p[axis] = sign;
          p[u] = tangent[i];
          p[v] = tangent[j];
          mesh.vertices.push_back(radius * p.normalized() + Eigen::Vector3d(0, 0, radius));
        }
      }
      auto index = [&](int i, int j) { return first + i * (n + 1) + j; };
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          // (u, v, axis) is right-handed: this order is counter-clockwise seen from +axis.
          const int a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1),
                    d = index(i, j + 1);
          if (sign > 0) {
            mesh.triangles.emplace_back(a, b, c);
            mesh.triangles.emplace_back(a, c, d);
          } else {
            mesh.triangles.emplace_back(a, c, b);
            mesh.triangles.emplace_back(a, d, c);
          }
        }
      }
    }
  }
  return mesh;
}

TriangleMesh makeBoxMesh(const Eigen::Vector3d& size) {
  TriangleMesh mesh;
  const Eigen::Vector3d half = size / 2.0;
  // Each face gets its own four corners so that no vertex is shared across a sharp edge.
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      const int u = (axis + 1) % 3;
      const int v = (axis + 2) % 3;
      const int first = static_cast<int>(mesh.vertices.size());
      for (int corner = 0; corner < 4; ++corner) {
        Eigen::Vector3d p;
        p[axis] = sign * half[axis];
        p[u] = (corner == 1 || corner == 2) ? half[u] : -half[u];
        p[v] = (corner >= 2) ? half[v] : -half[v];
        mesh.vertices.push_back(p + Eigen::Vector3d(0, 0, half.z()));
      }
      // (u, v, axis) is right-handed, so corners 0-1-2-3 run counter-clockwise seen from +axis.
      if (sign > 0) {
        mesh.triangles.emplace_back(first, first + 1, first + 2);
        mesh.triangles.emplace_back(first, first + 2, first + 3);
      } else {
        mesh.triangles.emplace_back(first, first + 2, first + 1);
        mesh.triangles.emplace_back(first, first + 3, first + 2);
      }
    }
  }
  return mesh;
}

TriangleMesh makeCylinderMesh(double radius, double height, int segments) {
  const Profile profile = {{0.0, 0.0}, {radius, 0.0}, {radius, height}, {0.0, height}};
  return revolve(profile, false, segments);
}

TriangleMesh makeTorusMesh(double centre_radius, double tube_radius, const ProceduralConfig& c) {
  Profile profile;
  appendArc(profile, Eigen::Vector2d(centre_radius, tube_radius), tube_radius, -kPi, kPi,
            2 * c.rings);
  profile.pop_back();  // the closed revolve joins the last point to the first
  return revolve(profile, true, c.segments);
}

// Spherical shell with its centre at the rim height, cut flat by z = 0 outside and by
// z = wall inside, so that it stands on a foot and has a floor as thick as the wall.
TriangleMesh makeShellBowlMesh(double outer, double wall, double rim_height, const ProceduralConfig& c) {
  const double inner = outer - wall;
  const Eigen::Vector2d centre(0.0, rim_height);
  const double foot_angle = std::asin(-rim_height / outer);  // where the outer sphere meets z=0
  const double floor_angle = std::asin((wall - rim_height) / inner);
  Profile profile = {{0.0, 0.0}};
  appendArc(profile, centre, outer, foot_angle, 0.0, c.rings);
  appendArc(profile, centre, inner, 0.0, floor_angle, c.rings);
  profile.emplace_back(0.0, wall);
  return revolve(profile, false, c.segments);
}

TriangleMesh makeBowlMesh(const ProceduralConfig& c) { return makeShellBowlMesh(0.5, 0.05, 0.4, c); }

// Box of the given size whose face at -x is centred on (start_x, 0, centre_z): a straight
// handle along +x.
TriangleMesh makeHandleMesh(double start_x, double length, double width, double thickness, double centre_z) {
  TriangleMesh handle = makeBoxMesh(Eigen::Vector3d(length, width, thickness));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << start_x + length / 2, 0.0, centre_z - thickness / 2;
  handle.transform(pose);
  return handle;
}

// Tube of radius tube_radius around an arc of radius arc_radius in the x-z plane centred at
// centre, from angle a0 to a1 (measured from +x towards +z), with both ends capped.
TriangleMesh makeTorusSegment(const Eigen::Vector3d& centre, double arc_radius,
                              double tube_radius, double a0, double a1, int arc_steps,
                              int tube_steps) {
  TriangleMesh mesh;
  for (int i = 0; i <= arc_steps; ++i) {
    const double a = a0 + (a1 - a0) * i / arc_steps;
    const Eigen::Vector3d radial(std::cos(a), 0.0, std::sin(a));
    const Eigen::Vector3d axis_point = centre + arc_radius * radial;
    for (int k = 0; k < tube_steps; ++k) {
      const double b = 2.0 * kPi * k / tube_steps;
      mesh.vertices.push_back(axis_point + tube_radius * (std::cos(b) * radial +
                                                          std::sin(b) * Eigen::Vector3d::UnitY()));
    }
  }
  for (int i = 0; i < arc_steps; ++i) {
    for (int k = 0; k < tube_steps; ++k) {
      const int next = (k + 1) % tube_steps;
      const int a = i * tube_steps + k, b = i * tube_steps + next;
      const int c = (i + 1) * tube_steps + k, d = (i + 1) * tube_steps + next;
      mesh.triangles.emplace_back(a, b, d);
      mesh.triangles.emplace_back(a, d, c);
    }
  }
  for (int end = 0; end < 2; ++end) {
    const int ring_start = end == 0 ? 0 : arc_steps * tube_steps;
    const double a = end == 0 ? a0 : a1;
    const int cap_centre = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(centre + arc_radius * Eigen::Vector3d(std::cos(a), 0.0, std::sin(a)));
    for (int k = 0; k < tube_steps; ++k) {
      const int next = (k + 1) % tube_steps;
      if (end == 0) {
        mesh.triangles.emplace_back(cap_centre, ring_start + next, ring_start + k);
      } else {
        mesh.triangles.emplace_back(cap_centre, ring_start + k, ring_start + next);
      }
    }
  }
  return mesh;
}

TriangleMesh makeMugMesh(const ProceduralConfig& c) {
  const double radius = 0.35, height = 0.85, wall = 0.05, floor_thickness = 0.06;
  const Profile cup = {{0.0, 0.0},
                       {radius, 0.0},
                       {radius, height},
                       {radius - wall, height},
                       {radius - wall, floor_thickness},
                       {0.0, floor_thickness}};
  TriangleMesh mesh = revolve(cup, false, c.segments);
  // The handle's capped ends sit inside the wall, so from outside it looks attached.
  const double handle_arc = 0.24, handle_tube = 0.03;
  mesh.append(makeTorusSegment(Eigen::Vector3d(radius - wall / 2, 0.0, height / 2), handle_arc,
                               handle_tube, -kPi / 2, kPi / 2, c.rings, std::max(8, c.rings / 2)));
  return mesh;
}

TriangleMesh makeFunnelMesh(int segments) {
  const double top_radius = 0.5, height = 1.0, spout_height = 0.35, spout_radius = 0.08;
  const double wall = 0.03;
  // Closed loop: up the outside of the spout and cone, across the rim, down the inside and
  // back across the annular bottom of the spout.
  const Profile profile = {{spout_radius, 0.0},
                           {spout_radius, spout_height},
                           {top_radius, height},
                           {top_radius - wall, height},
                           {spout_radius - wall, spout_height},
                           {spout_radius - wall, 0.0}};
  return revolve(profile, true, segments);
}

// A ladle-like spoon lying on its bowl: a shallow shell bowl (as the bowl's, diameter 0.28,
// depth 0.08) and a flat straight handle along +x that leaves the rim 5 mm below its top
// (unscaled units: the whole spoon is 1 long). The handle's end face lies inside the bowl's
// wall, between the inner and the outer sphere at every corner, so from outside the handle looks
// attached and nothing of it shows in the cavity.
TriangleMesh makeSpoonMesh(const ProceduralConfig& c) {
  const double outer = 0.14, wall = 0.02, rim_height = 0.08;
  const double handle_start = 0.125, handle_width = 0.08, handle_thickness = 0.03;
  TriangleMesh mesh = makeShellBowlMesh(outer, wall, rim_height, c);
  const double handle_end = 1.0 - outer;  // the spoon's length, from the far side of the bowl, is 1
  mesh.append(makeHandleMesh(handle_start, handle_end - handle_start, handle_width, handle_thickness,
                             rim_height - 0.005 - handle_thickness / 2));
  return mesh;
}

// A frying pan: an open cylinder (diameter 0.45, height 0.06, wall 0.012, floor 0.015) and a
// straight handle along +x just below the rim, its end face inside the wall (unscaled units: the
// pan and its handle are 1 long).
TriangleMesh makePanMesh(const ProceduralConfig& c) {
  const double radius = 0.225, height = 0.06, wall = 0.012, floor_thickness = 0.015;
  const Profile body = {{0.0, 0.0},
                        {radius, 0.0},
                        {radius, height},
                        {radius - wall, height},
                        {radius - wall, floor_thickness},
                        {0.0, floor_thickness}};
  TriangleMesh mesh = revolve(body, false, c.segments);
  const double handle_start = radius - wall / 2, handle_width = 0.05, handle_thickness = 0.025;
  mesh.append(makeHandleMesh(handle_start, 1.0 - radius - handle_start, handle_width, handle_thickness,
                             height - 0.01 - handle_thickness / 2));
  return mesh;
}

// Uniform scale so that the largest bounding-box side is size_m, then bounding box centred on
// x = y = 0 with its bottom on z = 0.
void normalisePlacement(TriangleMesh& mesh, double size_m) {
  mesh.scale(size_m / mesh.boundingBox().sizes().maxCoeff());
  placeOnTable(mesh);
}

constexpr double kCylinderRadiusFraction = 0.3;

}  // namespace

std::vector<std::string> proceduralObjectNames() {
  return {"sphere", "box", "cylinder", "torus", "bowl", "mug", "funnel", "spoon", "pan"};
}

TriangleMesh makeProceduralObject(const std::string& name, double size_m,
                                  const ProceduralConfig& config) {
  if (!std::isfinite(size_m) || size_m <= 0.0) {
    throw std::runtime_error("procedural object '" + name + "': size must be finite and > 0, got " +
                             std::to_string(size_m));
  }
  ProceduralConfig c = config;
  // Multiples of 4 put vertices on the +-x and +-y axes, so round shapes have exact extents.
  c.segments = std::max(8, (c.segments + 3) / 4 * 4);
  c.rings = std::max(4, (c.rings + 3) / 4 * 4);  // the sphere needs an even count per 90 degrees
  TriangleMesh mesh;
  if (name == "sphere") {
    mesh = makeSphereMesh(0.5, c.rings / 2);
  } else if (name == "box") {
    mesh = makeBoxMesh(Eigen::Vector3d::Ones());
  } else if (name == "cylinder") {
    mesh = makeCylinderMesh(kCylinderRadiusFraction, 1.0, c.segments);
  } else if (name == "torus") {
    mesh = makeTorusMesh(3.0 / 8.0, 1.0 / 8.0, c);
  } else if (name == "bowl") {
    mesh = makeBowlMesh(c);
  } else if (name == "mug") {
    mesh = makeMugMesh(c);
  } else if (name == "funnel") {
    mesh = makeFunnelMesh(c.segments);
  } else if (name == "spoon") {
    mesh = makeSpoonMesh(c);
  } else if (name == "pan") {
    mesh = makePanMesh(c);
  } else {
    std::string known;
    for (const auto& n : proceduralObjectNames()) known += (known.empty() ? "" : ", ") + n;
    throw std::runtime_error("unknown procedural object '" + name + "' (known: " + known + ")");
  }
  normalisePlacement(mesh, size_m);
  return mesh;
}

double sphereSignedDistance(const Eigen::Vector3d& centre, double radius,
                            const Eigen::Vector3d& point) {
  return (point - centre).norm() - radius;
}

double boxSignedDistance(const Eigen::Vector3d& centre, const Eigen::Vector3d& half_extents,
                         const Eigen::Vector3d& point) {
  const Eigen::Vector3d q = (point - centre).cwiseAbs() - half_extents;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double cylinderSignedDistance(const Eigen::Vector3d& base_centre, double radius, double height,
                              const Eigen::Vector3d& point) {
  const Eigen::Vector3d p = point - base_centre;
  const Eigen::Vector2d q(p.head<2>().norm() - radius, std::abs(p.z() - height / 2) - height / 2);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

std::optional<double> proceduralSignedDistance(const std::string& name, double size_m,
                                               const Eigen::Vector3d& point) {
  if (name == "sphere") {
    return sphereSignedDistance(Eigen::Vector3d(0, 0, size_m / 2), size_m / 2, point);
  }
  if (name == "box") {
    return boxSignedDistance(Eigen::Vector3d(0, 0, size_m / 2),
                             Eigen::Vector3d::Constant(size_m / 2), point);
  }
  if (name == "cylinder") {
    return cylinderSignedDistance(Eigen::Vector3d::Zero(), kCylinderRadiusFraction * size_m,
                                  size_m, point);
  }
  return std::nullopt;
}

}  // namespace probe_sim
