#include "gpatlas_geometry/cloud_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <system_error>

namespace gpatlas_geometry {

std::uint64_t PcdHeader::pointStepBytes() const {
  std::uint64_t step = 0;
  for (const PcdField& f : fields) step += static_cast<std::uint64_t>(f.size_bytes) * static_cast<std::uint64_t>(f.count);
  return step;
}

namespace {

// No PCD header is this long: random bytes are refused without reading a whole file in search of
// a DATA line.
constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
// PCL keeps WIDTH and HEIGHT in 32 bits, POINTS in a signed int.
constexpr std::uint64_t kMaxDimension = std::numeric_limits<std::uint32_t>::max();
constexpr std::uint64_t kMaxPoints = std::numeric_limits<std::int32_t>::max();
constexpr std::uint64_t kMaxFieldCount = 1 << 16;

std::vector<std::string> splitWords(const std::string& line) {
  std::vector<std::string> words;
  std::istringstream in(line);
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// Text from the file as a message can show it: printable, and short.
std::string shown(const std::string& text) {
  std::string out;
  for (const char c : text.substr(0, 40)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  return text.size() > 40 ? out + "..." : out;
}

bool parseWhole(const std::string& text, std::uint64_t* value) {
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, *value);
  return ec == std::errc() && ptr == end;
}

bool isNumber(const std::string& text) {
  char* end = nullptr;
  std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size();
}

struct Seen {
  bool fields{false}, size{false}, type{false}, width{false}, height{false}, points{false}, data{false};
};

// One value per field (SIZE, TYPE, COUNT): empty when they fit, else what is wrong.
std::string parsePerField(const std::vector<std::string>& w, PcdHeader* h) {
  const std::string& key = w[0];
  if (h->fields.empty()) return key + " before FIELDS";
  if (w.size() - 1 != h->fields.size())
    return key + " has " + std::to_string(w.size() - 1) + " values for " + std::to_string(h->fields.size()) + " FIELDS";
  for (std::size_t i = 0; i < h->fields.size(); ++i) {
    PcdField& f = h->fields[i];
    const std::string& v = w[i + 1];
    std::uint64_t n = 0;
    if (key == "TYPE") {
      if (v != "I" && v != "U" && v != "F") return "TYPE '" + shown(v) + "' of field " + f.name + " (I, U or F)";
      f.type = v[0];
    } else if (!parseWhole(v, &n)) {
      return key + " '" + shown(v) + "' of field " + f.name + " is not a whole number";
    } else if (key == "SIZE") {
      if (n != 1 && n != 2 && n != 4 && n != 8) return "SIZE " + v + " of field " + f.name + " (1, 2, 4 or 8 bytes)";
      f.size_bytes = static_cast<int>(n);
    } else {
      if (n < 1 || n > kMaxFieldCount)
        return "COUNT " + v + " of field " + f.name + " (1 to " + std::to_string(kMaxFieldCount) + ")";
      f.count = static_cast<int>(n);
    }
  }
  return "";
}

std::string parseDimension(const std::vector<std::string>& w, std::uint64_t max, std::uint64_t* value) {
  if (w.size() != 2) return w[0] + " needs one value, has " + std::to_string(w.size() - 1);
  if (!parseWhole(w[1], value) || *value > max)
    return w[0] + " '" + shown(w[1]) + "' is not a whole number from 0 to " + std::to_string(max);
  return "";
}

// One header line (its words): empty when it is understood, else what is wrong with it.
std::string parseHeaderLine(const std::vector<std::string>& w, PcdHeader* h, Seen* seen) {
  const std::string& key = w[0];
  if (key[0] == '#' || key == "VERSION") return "";
  if (key == "FIELDS" || key == "COLUMNS") {
    if (w.size() < 2) return "FIELDS names no field";
    h->fields.clear();
    for (std::size_t i = 1; i < w.size(); ++i) h->fields.push_back(PcdField{w[i], 4, 'F', 1});
    seen->fields = true;
    return "";
  }
  if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
    if (key == "SIZE") seen->size = true;
    if (key == "TYPE") seen->type = true;
    return parsePerField(w, h);
  }
  if (key == "WIDTH") {
    seen->width = true;
    return parseDimension(w, kMaxDimension, &h->width);
  }
  if (key == "HEIGHT") {
    seen->height = true;
    return parseDimension(w, kMaxDimension, &h->height);
  }
  if (key == "POINTS") {
    seen->points = true;
    return parseDimension(w, kMaxPoints, &h->points);
  }
  if (key == "VIEWPOINT") {
    if (w.size() != 8 || !std::all_of(w.begin() + 1, w.end(), isNumber)) return "VIEWPOINT needs 7 numbers";
    return "";
  }
  if (key == "DATA") {
    if (w.size() != 2) return "DATA needs one type (ascii, binary or binary_compressed)";
    if (w[1] != "ascii" && w[1] != "binary" && w[1] != "binary_compressed")
      return "unknown DATA type '" + shown(w[1]) + "' (ascii, binary or binary_compressed)";
    h->data = w[1];
    seen->data = true;
    return "";
  }
  return "'" + shown(key) + "' is not a PCD header keyword: not a PCD file, or a corrupt header";
}

// Reads the header lines up to DATA: empty when each is understood, else what is wrong.
std::string readHeaderLines(std::ifstream& in, PcdHeader* h, Seen* seen) {
  std::string text(kMaxHeaderBytes, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(in.gcount()));
  std::size_t start = 0;
  for (int line_number = 1; start < text.size() && !seen->data; ++line_number) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) {
      if (text.size() == kMaxHeaderBytes) break;
      end = text.size();
    }
    const std::vector<std::string> words = splitWords(text.substr(start, end - start));
    start = std::min(end + 1, text.size());
    if (words.empty()) continue;
    if (const std::string error = parseHeaderLine(words, h, seen); !error.empty())
      return "header line " + std::to_string(line_number) + ": " + error;
  }
  if (!seen->data)
    return "no DATA line in the first " + std::to_string(std::min(text.size(), kMaxHeaderBytes)) +
           " bytes: not a PCD file, or its header is cut short";
  h->data_offset_bytes = start;
  return "";
}

// Empty when the header, once read, describes a cloud this project can use; else what is missing.
std::string checkHeader(PcdHeader* h, const Seen& seen) {
  if (!seen.fields) return "no FIELDS line";
  if (!seen.size || !seen.type) return "no SIZE or no TYPE line";
  for (const PcdField& f : h->fields)
    if (f.type == 'F' && f.size_bytes != 4 && f.size_bytes != 8)
      return "field " + f.name + " is a float of " + std::to_string(f.size_bytes) + " bytes (4 or 8)";
  for (const char* axis : {"x", "y", "z"})
    if (std::none_of(h->fields.begin(), h->fields.end(), [&](const PcdField& f) { return f.name == axis; }))
      return std::string("no field ") + axis + " (the cloud needs x, y and z)";
  if (!seen.width) return "no WIDTH line";
  if (!seen.height) h->height = 1;
  if (!seen.points) h->points = h->width * h->height;
  if (h->width * h->height != h->points)
    return "WIDTH x HEIGHT (" + std::to_string(h->width) + " x " + std::to_string(h->height) + ") is not POINTS (" +
           std::to_string(h->points) + ")";
  if (h->points == 0) return "the header promises no points (POINTS 0)";
  return "";
}

std::string pointsPromised(const PcdHeader& h, std::uint64_t bytes) {
  return "the header promises " + std::to_string(h.points) + " points of " + std::to_string(h.pointStepBytes()) +
         " bytes (" + std::to_string(bytes) + " bytes of " + h.data + " data)";
}

std::string checkBinaryData(std::ifstream& in, const PcdHeader& h, std::uint64_t file_bytes) {
  const std::uint64_t need = h.points * h.pointStepBytes();
  const std::uint64_t have = file_bytes - h.data_offset_bytes;
  if (h.data == "binary")
    return have < need ? "truncated: " + pointsPromised(h, need) + ", the file has " + std::to_string(have) : "";
  // binary_compressed: the compressed and the unpacked size (32 bits each, little-endian), then LZF.
  if (have < 8) return "truncated: no compressed data after the header (" + std::to_string(have) + " bytes)";
  std::array<unsigned char, 8> sizes{};
  in.clear();
  in.seekg(static_cast<std::streamoff>(h.data_offset_bytes));
  in.read(reinterpret_cast<char*>(sizes.data()), 8);
  const auto word = [&](int at) {
    std::uint64_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | sizes[static_cast<std::size_t>(at + i)];
    return v;
  };
  const std::uint64_t compressed = word(0), unpacked = word(4);
  if (unpacked != need)
    return "corrupt: the compressed data unpacks to " + std::to_string(unpacked) + " bytes, " + pointsPromised(h, need);
  if (compressed > have - 8)
    return "truncated: " + std::to_string(compressed) + " bytes of compressed data promised, the file has " +
           std::to_string(have - 8);
  return "";
}

std::string checkAsciiData(std::ifstream& in, const PcdHeader& h) {
  std::size_t values_per_point = 0;
  for (const PcdField& f : h.fields) values_per_point += static_cast<std::size_t>(f.count);
  in.clear();
  in.seekg(static_cast<std::streamoff>(h.data_offset_bytes));
  std::uint64_t rows = 0;
  for (std::string line; std::getline(in, line);) {
    const std::vector<std::string> words = splitWords(line);
    if (words.empty()) continue;
    if (++rows > h.points) return "more data rows than the " + std::to_string(h.points) + " points of the header";
    const std::string row = "data row " + std::to_string(rows) + ": ";
    if (words.size() != values_per_point)
      return row + std::to_string(words.size()) + " values, the fields need " + std::to_string(values_per_point);
    const auto bad = std::find_if_not(words.begin(), words.end(), isNumber);
    if (bad != words.end()) return row + "'" + shown(*bad) + "' is not a number";
  }
  if (rows < h.points)
    return "truncated: the header promises " + std::to_string(h.points) + " points, the data has " +
           std::to_string(rows) + " rows";
  return "";
}

}  // namespace

std::string checkPcdFile(const std::string& path, PcdHeader* header) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return path + ": no such file";
  const std::uint64_t file_bytes = std::filesystem::file_size(path, ec);
  if (ec) return path + ": cannot read its size (" + ec.message() + ")";
  if (file_bytes == 0) return path + ": the file is empty (0 bytes)";
  std::ifstream in(path, std::ios::binary);
  if (!in) return path + ": cannot be opened";
  PcdHeader h;
  Seen seen;
  std::string error = readHeaderLines(in, &h, &seen);
  if (error.empty()) error = checkHeader(&h, seen);
  if (error.empty() && h.points > std::numeric_limits<std::uint64_t>::max() / std::max<std::uint64_t>(1, h.pointStepBytes()))
    error = "the header promises more data than a file holds";
  if (error.empty()) error = h.data == "ascii" ? checkAsciiData(in, h) : checkBinaryData(in, h, file_bytes);
  if (header) *header = h;
  return error.empty() ? "" : path + ": " + error;
}

}  // namespace gpatlas_geometry
