#pragma once

// The space a camera view did not observe: its shadow, the volume behind the surface it saw as
// seen from the sensor. The GP fills it with a smooth guess (the back of what was seen) and the
// atlas plans only on that guess, so a part hidden there (a mug's handle behind its body) is
// never predicted and never touched. A frontier strategy (frontier_strategy.h) looks there.

#include "gpatlas_core/common/types.h"

#include <string>
#include <vector>

namespace gpatlas_core {

// One camera view: the sensor's optical centre and the object's points it saw (world frame,
// after segmentation: the table and the background removed).
struct CameraView {
  Vector3 origin{Vector3::Zero()};
  std::vector<Vector3> points;
};

// Empty when the view is usable (a finite origin, finite points); otherwise what is wrong.
std::string validate(const CameraView& view);

// Which points no view observed. Each view becomes a depth map over directions from its origin
// (a perspective grid of bins about the points' mean direction): per bin the nearest point's range.
// A point whose range exceeds the nearest range of its bin and of the bins around it, by more than
// a margin, lies behind seen surface; a point whose bin and neighbours hold no view point was on
// a ray that reached the table or the background, so it was seen free.
class ViewShadow {
 public:
  struct Config {
    // A bin's side at the views' median range (metres): a few of the camera's pixels, so that
    // every bin inside the silhouette holds a point.
    double bin_m{0.004};
    // A point counts as behind the seen surface only this far behind it (metres): the depth
    // noise, and the seen surface's own thickness.
    double depth_margin_m{0.005};
  };

  ViewShadow() = default;
  // Views without a finite point are skipped; throws std::invalid_argument for a bad
  // config (bin_m or depth_margin_m not positive and finite).
  ViewShadow(const std::vector<CameraView>& views, const Config& config);

  // No view (then nothing is known to be hidden: hidden() is always false).
  bool empty() const { return maps_.empty(); }
  // True when x lies behind seen surface in every view: no camera observed it.
  bool hidden(const Vector3& x) const;

 private:
  struct DepthMap {
    Vector3 origin, axis, u, v;  // the projection's frame: axis forward, u and v across it
    double pitch{0.0};           // a bin's side in the image plane at unit distance
    int i0{0}, j0{0}, width{0}, height{0};
    std::vector<float> nearest;  // per bin, the nearest point's range (infinity: empty)
    bool hides(const Vector3& x, double margin) const;
  };
  std::vector<DepthMap> maps_;
  Config config_;
};

}  // namespace gpatlas_core
