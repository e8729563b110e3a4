#pragma once

// The check a PCD cloud file passes before PCL reads it: PCL's loadPCDFile dereferences what a
// header promised without asking whether it was there (an empty file or random bytes crash it),
// so the header is read here first, and the data it promises is counted against the file.
// No PCL: the header is plain text (PCD v0.7), and this way any reader can ask first.

#include <cstdint>
#include <string>
#include <vector>

namespace gpatlas_geometry {

struct PcdField {
  std::string name;
  int size_bytes{4};  // of one element: 1, 2, 4 or 8
  char type{'F'};     // I (signed), U (unsigned) or F (floating point)
  int count{1};       // elements per point
};

struct PcdHeader {
  std::vector<PcdField> fields;
  std::uint64_t width{0};
  std::uint64_t height{0};
  std::uint64_t points{0};
  std::string data;                    // ascii, binary or binary_compressed
  std::uint64_t data_offset_bytes{0};  // where the data starts in the file
  std::uint64_t pointStepBytes() const;
};

// Empty when the file at `path` is a PCD file whose header is complete and consistent (FIELDS
// with x, y and z, SIZE, TYPE, COUNT, WIDTH x HEIGHT = POINTS > 0, a known DATA type) and whose
// data holds every point the header promises; else "<path>: <what is wrong>". Fills *header
// when it is given and the header could be read.
std::string checkPcdFile(const std::string& path, PcdHeader* header = nullptr);

}  // namespace gpatlas_geometry
