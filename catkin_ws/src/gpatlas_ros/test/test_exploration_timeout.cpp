#include <gpatlas_msgs/Capture.h>

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
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

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_exploration_timeout");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
