#include "import/morphology3d.hpp"

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace burrbench::data_schema::import::detail {
namespace {

int as_int(std::size_t n) { return static_cast<int>(n); }

// Applies a 2-D OpenCV operation to every z slice in place.
template <typename T, typename Op>
void per_slice(std::vector<T>& v, const Dims& d, int cv_type, Op op) {
  const std::size_t plane = d[0] * d[1];
  for (std::size_t z = 0; z < d[2]; ++z) {
    cv::Mat s(as_int(d[1]), as_int(d[0]), cv_type, v.data() + z * plane);
    cv::Mat out;
    op(s, out);
    out.copyTo(s);
  }
}

// Along z: out[z] = reduce(in[z-r .. z+r]) clipped to the volume.
template <typename T, typename R>
std::vector<T> z_pass(const std::vector<T>& v, const Dims& d, int r, T init, R reduce) {
  const std::size_t plane = d[0] * d[1];
  std::vector<T> out(v.size());
  const auto nz = static_cast<long>(d[2]);
  for (long z = 0; z < nz; ++z) {
    const long lo = std::max(0L, z - r), hi = std::min(nz - 1, z + r);
    T* o = out.data() + static_cast<std::size_t>(z) * plane;
    std::fill(o, o + plane, init);
    for (long k = lo; k <= hi; ++k) {
      const T* s = v.data() + static_cast<std::size_t>(k) * plane;
      for (std::size_t i = 0; i < plane; ++i) o[i] = reduce(o[i], s[i]);
    }
  }
  return out;
}

}  // namespace

std::vector<float> box_count(const std::vector<std::uint8_t>& m, const Dims& d, int r) {
  const std::size_t plane = d[0] * d[1];
  std::vector<float> t(m.size());
  // x, y: OpenCV's box filter from each mask slice straight into the result's slice.
  for (std::size_t z = 0; z < d[2]; ++z) {
    const cv::Mat s(as_int(d[1]), as_int(d[0]), CV_8U, const_cast<std::uint8_t*>(m.data() + z * plane));
    cv::Mat o(as_int(d[1]), as_int(d[0]), CV_32F, t.data() + z * plane);
    cv::boxFilter(s, o, CV_32F, cv::Size(2 * r + 1, 2 * r + 1), cv::Point(-1, -1), false, cv::BORDER_CONSTANT);
  }
  if (r <= 0 || d[2] == 0) return t;
  // z, in place: a running sum over the window. Plane z is overwritten with its window's
  // sum; the sum later drops plane z's original, which waits in a ring of r + 1 planes
  // (plane z - r - 1 leaves when plane z enters, so they share the slot z mod (r + 1)).
  const auto nz = static_cast<long>(d[2]);
  std::vector<float> acc(plane, 0.0f), ring(std::size_t(r + 1) * plane);
  for (long k = 0; k <= std::min<long>(r, nz - 1); ++k) {
    const float* s = t.data() + std::size_t(k) * plane;
    for (std::size_t i = 0; i < plane; ++i) acc[i] += s[i];
  }
  for (long z = 0; z < nz; ++z) {
    float* p = t.data() + std::size_t(z) * plane;
    float* slot = ring.data() + std::size_t(z % (r + 1)) * plane;
    if (z > 0) {
      if (z + r < nz) {
        const float* in = t.data() + std::size_t(z + r) * plane;
        for (std::size_t i = 0; i < plane; ++i) acc[i] += in[i];
      }
      if (z - r - 1 >= 0)
        for (std::size_t i = 0; i < plane; ++i) acc[i] -= slot[i];
    }
    std::copy(p, p + plane, slot);
    std::copy(acc.begin(), acc.end(), p);
  }
  return t;
}

std::vector<std::uint8_t> dilate(const std::vector<std::uint8_t>& m, const Dims& d, int r) {
  if (r <= 0) return m;
  std::vector<std::uint8_t> t = m;
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1));
  per_slice(t, d, CV_8U, [&](const cv::Mat& s, cv::Mat& o) { cv::dilate(s, o, k); });
  return z_pass<std::uint8_t>(t, d, r, 0, [](std::uint8_t a, std::uint8_t b) { return std::max(a, b); });
}

std::vector<std::uint8_t> erode(const std::vector<std::uint8_t>& m, const Dims& d, int r) {
  if (r <= 0) return m;
  std::vector<std::uint8_t> t = m;
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1));
  per_slice(t, d, CV_8U, [&](const cv::Mat& s, cv::Mat& o) { cv::erode(s, o, k); });
  return z_pass<std::uint8_t>(t, d, r, 255, [](std::uint8_t a, std::uint8_t b) { return std::min(a, b); });
}

}  // namespace burrbench::data_schema::import::detail
