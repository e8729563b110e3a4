#include "probe_sim/object_mesh.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

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
  if (!out) fail(path, std::string("cannot write the STL (") + std::strerror(errno) + ")");
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
  if (!out) fail(path, "error while writing the STL");
}

}  // namespace probe_sim
