#include <gtest/gtest.h>
#include <ros/ros.h>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

namespace fs = std::filesystem;

namespace {

class BadCloudFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("gpatlas_bad_cloud_file_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& bytes) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }

  // Runs cloud_file_publisher on `path` (killed after 30 s: a node that took the file would
  // wait for subscribers and then spin) and expects its error exit, 1, with a message on stderr
  // that names the file and says `what`.
  void expectErrorExit(const std::string& path, const std::string& what) const {
    const std::string err = (dir_ / "stderr.txt").string();
    const std::string command = "timeout 30 rosrun gpatlas_ros cloud_file_publisher __name:=bad_cloud_file_publisher _file:=" +
                                path + " _wait_for_subscriber_s:=0 > /dev/null 2> " + err;
    const int status = std::system(command.c_str());
    std::ifstream in(err);
    const std::string message((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::printf("[bad cloud file] %s", message.c_str());
    ASSERT_TRUE(WIFEXITED(status)) << path << ": the shell was killed by signal " << WTERMSIG(status);
    // A crash of the node shows as the shell's 128 + signal (139 for SIGSEGV), a hang as 124.
    EXPECT_EQ(WEXITSTATUS(status), 1) << path << "\n" << message;
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(what), std::string::npos) << "'" << message << "' does not say '" << what << "'";
  }

  fs::path dir_;
};

TEST_F(BadCloudFile, AnEmptyPcdIsAnErrorNotACrash) {
  expectErrorExit(write("empty.pcd", ""), "the file is empty (0 bytes)");
}

TEST_F(BadCloudFile, RandomBytesAreAnErrorNotACrash) {
  std::mt19937 rng(51);
  std::string bytes(4096, '\0');
  for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
  expectErrorExit(write("random.pcd", bytes), "not a PCD file");
}

// The behaviour the two above match: the node's answer to a file that is not there.
TEST_F(BadCloudFile, AMissingFileIsAnError) { expectErrorExit((dir_ / "absent.pcd").string(), "no such file"); }

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bad_cloud_file");
  return RUN_ALL_TESTS();
}
