#include <gpatlas_msgs/Capture.h>

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace {

TEST(ExplorationNode, GivesUpOnAServiceThatNeverAnswers) {
  ros::NodeHandle nh;
  std::atomic<bool> called{false}, release{false};
  // Answers only after 30 s (or when the test ends): a driver that hangs.
  ros::ServiceServer hanging = nh.advertiseService<gpatlas_msgs::Capture::Request, gpatlas_msgs::Capture::Response>(
      "/hanging/capture", [&](gpatlas_msgs::Capture::Request&, gpatlas_msgs::Capture::Response& response) {
        called = true;
        for (int i = 0; i < 300 && !release; ++i) ros::WallDuration(0.1).sleep();
        response.success = false;
        response.message = "hung";
        return true;
      });

  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("gpatlas_exploration_timeout_test_" + std::to_string(::getpid()));
  const std::string command =
      "rosrun gpatlas_ros exploration_node __name:=timeout_exploration capture:=/hanging/capture "
      "ground_truth:=/no_ground_truth _call_timeout_s:=1.0 _service_timeout_s:=5.0 _results_dir:=" +
      dir.string() + " > /dev/null 2>&1";
  const auto start = std::chrono::steady_clock::now();
  const int status = std::system(command.c_str());
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  release = true;

  EXPECT_TRUE(called) << "the exploration never called the capture service";
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);  // the exploration's error exit, not a crash nor a finish
  // Start-up, 2 s looking for a ground truth, 1 s on the capture. Without the timeout it would
  // wait the 30 s of the hanging call, then service_timeout_s for a model.
  EXPECT_LT(elapsed, 20.0);
}

// A service that is never offered: the node waits service_timeout_s for it, and says after 10 s
// which service it waits for and from which remap (issue 51: a wait of more than 10 s is not
// silent), then gives up.
TEST(ExplorationNode, SaysWhichServiceItWaitsFor) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("gpatlas_exploration_wait_test_" + std::to_string(::getpid()));
  const std::filesystem::path log = dir.string() + ".log";
  const std::string command =
      "rosrun gpatlas_ros exploration_node __name:=wait_exploration capture:=/nobody/capture "
      "ground_truth:=/no_ground_truth _service_timeout_s:=13.0 _results_dir:=" +
      dir.string() + " > " + log.string() + " 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream file(log);
  const std::string output((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  std::filesystem::remove(log);
  std::filesystem::remove_all(dir);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1) << output;
  // One report at 10 s (the next would come at 20 s, after the 13 s it waits).
  const std::string report = "waiting 10";
  const std::size_t at = output.find(report);
  ASSERT_NE(at, std::string::npos) << output;
  const std::string line = output.substr(at, output.find('\n', at) - at);
  EXPECT_NE(line.find("the service /nobody/capture (remapped from `capture`) to be offered"), std::string::npos) << line;
  EXPECT_NE(line.find("service_timeout_s (13 s)"), std::string::npos) << line;
  EXPECT_EQ(output.find("waiting 2"), std::string::npos) << output;
  EXPECT_NE(output.find("service /nobody/capture not available after 13 s"), std::string::npos) << output;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_exploration_timeout");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
