// checkPcdFile on files written here: PCL's own writer makes the good ones (ascii, binary,
// binary_compressed), and PCL's reader is the truth that they load with the same point count;
// the bad ones (empty, random bytes, cut short, inconsistent) are refused with the file's name
// and what is wrong.

#include "gpatlas_geometry/cloud_file.h"

#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace fs = std::filesystem;
using gpatlas_geometry::checkPcdFile;
using gpatlas_geometry::PcdHeader;

namespace {

const char* const kAsciiHeader =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS x y z\n"
    "SIZE 4 4 4\n"
    "TYPE F F F\n"
    "COUNT 1 1 1\n"
    "WIDTH 3\n"
    "HEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 3\n";

class CloudFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("gpatlas_cloud_file_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  static std::string bytesOf(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // A cloud of n points written by PCL: 0 ascii, 1 binary, 2 binary_compressed.
  std::string writeWithPcl(const std::string& name, int format, std::size_t n) const {
    pcl::PointCloud<pcl::PointXYZ> cloud;
    for (std::size_t i = 0; i < n; ++i) cloud.push_back(pcl::PointXYZ(0.01f * i, -0.02f * i, 0.5f + 0.001f * i));
    const std::string path = (dir_ / name).string();
    pcl::PCDWriter writer;
    const int status = format == 0   ? writer.writeASCII(path, cloud)
                       : format == 1 ? writer.writeBinary(path, cloud)
                                     : writer.writeBinaryCompressed(path, cloud);
    EXPECT_EQ(status, 0) << "PCL could not write " << path;
    return path;
  }
  // The refusal names the file (so it is not empty) and says `what`.
  static void expectRefused(const std::string& path, const std::string& what) {
    const std::string error = checkPcdFile(path);
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find(what), std::string::npos) << "'" << error << "' does not say '" << what << "'";
  }
  static std::size_t pclPointCount(const std::string& path) {
    pcl::PCLPointCloud2 cloud;
    EXPECT_EQ(pcl::io::loadPCDFile(path, cloud), 0) << path;
    return static_cast<std::size_t>(cloud.width) * cloud.height;
  }

  fs::path dir_;
};

TEST_F(CloudFile, GoodFilesPassWithThePointCountPclReads) {
  const std::string ascii = write("hand.pcd", std::string(kAsciiHeader) + "DATA ascii\n1 2 3\n4 5 6\nnan nan nan\n");
  const std::string files[] = {ascii, writeWithPcl("ascii.pcd", 0, 7), writeWithPcl("binary.pcd", 1, 11),
                               writeWithPcl("compressed.pcd", 2, 13)};
  const std::size_t counts[] = {3, 7, 11, 13};
  for (int i = 0; i < 4; ++i) {
    PcdHeader header;
    EXPECT_EQ(checkPcdFile(files[i], &header), "");
    EXPECT_EQ(header.points, counts[i]) << files[i];
    EXPECT_EQ(header.width * header.height, counts[i]) << files[i];
    EXPECT_EQ(pclPointCount(files[i]), counts[i]) << files[i];
  }
  PcdHeader header;
  checkPcdFile(files[2], &header);
  EXPECT_EQ(header.data, "binary");
  EXPECT_EQ(header.data_offset_bytes + header.points * header.pointStepBytes(), fs::file_size(files[2]));
}

TEST_F(CloudFile, EmptyAndMissingFilesAreRefused) {
  expectRefused(write("empty.pcd", ""), "empty (0 bytes)");
  expectRefused((dir_ / "absent.pcd").string(), "no such file");
  expectRefused(dir_.string(), "no such file");
}

TEST_F(CloudFile, RandomBytesAreRefused) {
  std::mt19937 rng(51);
  for (int trial = 0; trial < 20; ++trial) {
    std::string bytes(4096, '\0');
    for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
    expectRefused(write("random" + std::to_string(trial) + ".pcd", bytes), "");
  }
  // Text that is not a PCD header, and a header cut before its DATA line.
  expectRefused(write("text.pcd", "hello world\n"), "'hello' is not a PCD header keyword");
  expectRefused(write("cut.pcd", kAsciiHeader), "no DATA line");
}

TEST_F(CloudFile, AHeaderWithoutItsDataIsRefused) {
  expectRefused(write("ascii.pcd", std::string(kAsciiHeader) + "DATA ascii\n"), "promises 3 points, the data has 0");
  expectRefused(write("binary.pcd", std::string(kAsciiHeader) + "DATA binary\n"), "truncated");
  expectRefused(write("compressed.pcd", std::string(kAsciiHeader) + "DATA binary_compressed\n"), "truncated");
}

TEST_F(CloudFile, TruncatedDataIsRefused) {
  const std::string binary = bytesOf(writeWithPcl("full.pcd", 1, 20));
  const std::string cut = write("cut.pcd", binary.substr(0, binary.size() - 5));
  expectRefused(cut, "truncated");
  // PCL refuses it too (it does not crash on this one): the check agrees with the reader.
  pcl::PCLPointCloud2 cloud;
  EXPECT_LT(pcl::io::loadPCDFile(cut, cloud), 0);

  const std::string compressed = bytesOf(writeWithPcl("full_compressed.pcd", 2, 200));
  expectRefused(write("cut_compressed.pcd", compressed.substr(0, compressed.size() - 3)), "truncated");
  expectRefused(write("ascii.pcd", std::string(kAsciiHeader) + "DATA ascii\n1 2 3\n4 5 6\n"),
                "promises 3 points, the data has 2");
}

TEST_F(CloudFile, AnInconsistentHeaderIsRefused) {
  const std::string data = "DATA ascii\n1 2 3\n4 5 6\n7 8 9\n";
  auto edited = [&](const std::string& from, const std::string& to) {
    std::string header = kAsciiHeader;
    header.replace(header.find(from), from.size(), to);
    return header + data;
  };
  expectRefused(write("no_xyz.pcd", edited("FIELDS x y z", "FIELDS a b c")), "no field x");
  expectRefused(write("no_z.pcd", edited("FIELDS x y z", "FIELDS x y w")), "no field z");
  expectRefused(write("points.pcd", edited("POINTS 3", "POINTS 4")), "WIDTH x HEIGHT (3 x 1) is not POINTS (4)");
  expectRefused(write("zero.pcd", edited("WIDTH 3", "WIDTH 0")), "WIDTH x HEIGHT (0 x 1) is not POINTS (3)");
  expectRefused(write("negative.pcd", edited("WIDTH 3", "WIDTH -3")), "WIDTH '-3' is not a whole number");
  expectRefused(write("size.pcd", edited("SIZE 4 4 4", "SIZE 4 4")), "SIZE has 2 values for 3 FIELDS");
  expectRefused(write("type.pcd", edited("TYPE F F F", "TYPE F F Q")), "TYPE 'Q' of field z");
  expectRefused(write("data.pcd", std::string(kAsciiHeader) + "DATA foo\n1 2 3\n"), "unknown DATA type 'foo'");
  const std::string no_points = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA ascii\n";
  expectRefused(write("no_points.pcd", no_points), "promises no points");
  expectRefused(write("word.pcd", std::string(kAsciiHeader) + "DATA ascii\n1 2 3\n4 five 6\n7 8 9\n"),
                "data row 2: 'five' is not a number");
  expectRefused(write("row.pcd", std::string(kAsciiHeader) + "DATA ascii\n1 2 3\n4 5\n7 8 9\n"),
                "data row 2: 2 values, the fields need 3");
}

}  // namespace
