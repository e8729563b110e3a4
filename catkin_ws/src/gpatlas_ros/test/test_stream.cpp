// stream.test: a 30 Hz stream of a real cloud (the same view every time) leaves no backlog of
// fits, and the
// nodelet manager's memory at the end is within ~max_memory_growth of what it was when the first
// model came: a refit of the same view holds no more than the first fit did.

#include "mug_cloud_test.h"

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <algorithm>
#include <cstdio>

namespace {

using mug_cloud_test::Arrivals;

// The manager's resident memory as the test goes: when the first model came, the peak, the end.
class MemoryTrace {
 public:
  explicit MemoryTrace(int pid) : pid_(pid) {}
  void sample(bool have_model) {
    const double mb = mug_cloud_test::residentMb(pid_);
    if (mb < 0.0) return;
    last_ = mb;
    peak_ = std::max(peak_, mb);
    if (have_model && first_model_ < 0.0) first_model_ = mb;
    const ros::WallTime now = ros::WallTime::now();
    if (now >= next_print_) {
      std::printf("[stream] manager RSS %.0f MB%s\n", mb, have_model ? "" : " (no model yet)");
      next_print_ = now + ros::WallDuration(10.0);
    }
  }
  double firstModel() const { return first_model_; }
  double peak() const { return peak_; }
  double last() const { return last_; }

 private:
  int pid_;
  double first_model_{-1.0}, peak_{0.0}, last_{-1.0};
  ros::WallTime next_print_;
};

TEST(Stream, AFastCameraLeavesAtMostOneFitQueuedAndItsMemoryComesBack) {
  std::string pcd;
  if (mug_cloud_test::recordedCloudAbsent(&pcd)) GTEST_SKIP() << mug_cloud_test::skipMessage(pcd);
  ros::NodeHandle pnh("~");
  const double max_growth = pnh.param("max_memory_growth", 1.25);
  const Arrivals arrivals{ros::NodeHandle()};
  ros::AsyncSpinner spinner(2);
  spinner.start();
  int pid = 0;
  for (const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(60.0); !pid && ros::WallTime::now() < until;
       ros::WallDuration(0.2).sleep())
    pid = mug_cloud_test::nodePid("/gpatlas/gpatlas_manager");
  ASSERT_GT(pid, 0) << "no pid from /gpatlas/gpatlas_manager";
  MemoryTrace memory(pid);

  // The stream: until no cloud has come for 2 s, once duration_s (stream.test's) has passed since
  // the first cloud. The camera started before its first cloud came, so its stream is over then:
  // a loaded machine can hold the stream up for seconds, and a pause is not its end.
  const double duration_s = pnh.param("duration_s", 60.0);
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(duration_s + 180.0);
  ros::WallTime first_cloud;
  for (;;) {
    ros::WallDuration(0.1).sleep();
    memory.sample(!arrivals.models().empty());
    ASSERT_LT(ros::WallTime::now(), give_up) << "the stream did not start and end";
    if (arrivals.clouds() == 0) continue;
    if (first_cloud.isZero()) first_cloud = arrivals.lastCloud();
    const ros::WallTime now = ros::WallTime::now();
    if ((now - first_cloud).toSec() >= duration_s && (now - arrivals.lastCloud()).toSec() > 2.0) break;
  }
  // Then long enough for a backlog to show: 20 s with no new model, or 90 s in all.
  const ros::WallTime stream_end = arrivals.lastCloud();
  const ros::WallTime quiet_limit = ros::WallTime::now() + ros::WallDuration(90.0);
  for (;;) {
    ros::WallDuration(0.2).sleep();
    memory.sample(!arrivals.models().empty());
    const std::vector<ros::WallTime> models = arrivals.models();
    const ros::WallTime latest = models.empty() ? stream_end : std::max(stream_end, models.back());
    if ((ros::WallTime::now() - latest).toSec() > 20.0 || ros::WallTime::now() > quiet_limit) break;
  }
  const std::vector<ros::WallTime> models = arrivals.models();
  const std::size_t clouds = arrivals.clouds();
  const auto after_end = static_cast<std::size_t>(
      std::count_if(models.begin(), models.end(), [&](const ros::WallTime& t) { return t > stream_end; }));
  std::printf("[stream] %zu clouds in, %zu models out, %zu of them after the last cloud (%.1f s after it)\n", clouds,
              models.size(), after_end, models.empty() ? 0.0 : (models.back() - stream_end).toSec());
  std::printf("[stream] manager RSS: %.0f MB at the first model, peak %.0f MB, %.0f MB at the end (%.2fx)\n",
              memory.firstModel(), memory.peak(), memory.last(), memory.last() / memory.firstModel());
  ASSERT_GT(clouds, 300u) << "the camera streamed too little to test anything";
  ASSERT_GE(models.size(), 3u) << "too few models from the stream to see memory grow";
  // Two stages that each take the newest input: after the last cloud, the fit under way, then the
  // cloud segmentation is working on, then the one waiting for it can each give a model, if the
  // fit ends between them (three). A queue would give dozens at 30 Hz.
  EXPECT_LE(after_end, 3u) << "a backlog of fits ran on after the stream";
  ASSERT_GT(memory.firstModel(), 0.0);
  EXPECT_LE(memory.last(), max_growth * memory.firstModel())
      << "the manager kept memory over " << models.size() << " fits of the same view";
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_stream");
  return RUN_ALL_TESTS();
}
