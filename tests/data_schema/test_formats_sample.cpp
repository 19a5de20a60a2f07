// Sample volume (HDF5): round trip in both χ encodings, validation, broken files.
#include <cstring>

#include "burrbench/data_schema/sample_volume.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::test::expect_input_error;
using burrbench::test::expect_rejected_unchanged;
using burrbench::test::TempDir;

namespace {

// 9×4×3 with three classes; χ values k/255 so the counter encoding is exact too.
bb::SampleVolume make_sample() {
  bb::SampleVolume v;
  v.dims = {9, 4, 3};
  v.voxel_mm = 0.125;
  v.origin_mm = {-3.5, 0.25, 1e-3};
  v.classes = {{1, "compact"}, {2, "trabecular"}, {5, "implant"}};
  v.labels.resize(v.voxel_count());
  v.fraction.resize(v.voxel_count());
  for (std::size_t z = 0; z < 3; ++z)
    for (std::size_t y = 0; y < 4; ++y)
      for (std::size_t x = 0; x < 9; ++x) {
        const std::size_t i = v.index(x, y, z);
        const std::uint8_t l = std::uint8_t((x + 2 * y + 3 * z) % 4);
        v.labels[i] = l == 3 ? 5 : l;
        v.fraction[i] = l == 0 ? 0.0f : static_cast<float>((x * 37 + y * 11 + z) % 256) / 255.0f;
      }
  v.sources = {{"/data/ct.nrrd", std::string(64, 'a')}, {"labels.nrrd", std::string(64, '0')}};
  v.segmentation_json = R"({"threshold":{"method":"otsu","value":1234.5},"radius_mm":0.5})";
  v.provenance = burrbench::make_provenance({});
  v.provenance.inputs = v.sources;
  return v;
}

void expect_same(const bb::SampleVolume& a, const bb::SampleVolume& b) {
  EXPECT_EQ(b.dims, a.dims);
  EXPECT_EQ(b.voxel_mm, a.voxel_mm);
  EXPECT_EQ(b.origin_mm, a.origin_mm);
  EXPECT_EQ(b.labels, a.labels);
  ASSERT_EQ(b.fraction.size(), a.fraction.size());
  EXPECT_EQ(std::memcmp(b.fraction.data(), a.fraction.data(), a.fraction.size() * sizeof(float)), 0);
  EXPECT_EQ(b.classes, a.classes);
  ASSERT_EQ(b.sources.size(), a.sources.size());
  for (std::size_t i = 0; i < a.sources.size(); ++i) {
    EXPECT_EQ(b.sources[i].path, a.sources[i].path);
    EXPECT_EQ(b.sources[i].sha256, a.sources[i].sha256);
  }
  EXPECT_EQ(b.segmentation_json, a.segmentation_json);
  EXPECT_EQ(b.provenance.software_version, a.provenance.software_version);
  EXPECT_EQ(b.provenance.created_utc, a.provenance.created_utc);
  EXPECT_EQ(b.provenance.inputs.size(), a.provenance.inputs.size());
}

}  // namespace

TEST(FormatsSample, RoundTripFloat32IsBitExact) {
  TempDir dir;
  const auto a = make_sample();
  bb::write_sample(dir / "s.h5", a);
  expect_same(a, bb::read_sample(dir / "s.h5"));
  const auto h = bb::read_sample_header(dir / "s.h5");
  EXPECT_EQ(h.dims, a.dims);
  EXPECT_EQ(h.encoding, bb::FractionEncoding::kFloat32);
  EXPECT_EQ(h.format_version, "1.0");
}

TEST(FormatsSample, RoundTripCounter255) {
  TempDir dir;
  const auto a = make_sample();
  bb::write_sample(dir / "s.h5", a, bb::FractionEncoding::kCounter8);
  expect_same(a, bb::read_sample(dir / "s.h5"));  // χ = n/255 survives exactly
  EXPECT_EQ(bb::read_sample_header(dir / "s.h5").encoding, bb::FractionEncoding::kCounter8);
  // Arbitrary χ is quantised to the nearest n/255.
  auto q = a;
  q.fraction[1] = 0.5f;  // label of voxel 1 is 1
  ASSERT_EQ(q.labels[1], 1);
  bb::write_sample(dir / "q.h5", q, bb::FractionEncoding::kCounter8);
  EXPECT_EQ(bb::read_sample(dir / "q.h5").fraction[1], 128.0f / 255.0f);
}

TEST(FormatsSample, ValidatorNamesVoxelAndExpectation) {
  TempDir dir;
  const auto base = make_sample();
  auto check = [&](auto mutate, std::initializer_list<std::string> frags) {
    auto v = base;
    mutate(v);
    expect_input_error([&] { bb::write_sample(dir / "bad.h5", v); }, frags);
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.h5"));
  };
  check([](bb::SampleVolume& v) { v.fraction[v.index(1, 0, 0)] = 1.5f; },
        {"bad.h5: /fraction[z=0][y=0][x=1]: expected a bone fraction in [0, 1], got 1.5"});
  check([](bb::SampleVolume& v) { v.fraction[v.index(1, 0, 0)] = NAN; }, {"/fraction[z=0][y=0][x=1]"});
  check([](bb::SampleVolume& v) { v.fraction[v.index(0, 0, 0)] = 0.5f; },
        {"/fraction[z=0][y=0][x=0]", "0 where the label is 0"});
  check([](bb::SampleVolume& v) { v.labels[v.index(2, 1, 2)] = 7; },
        {"/labels[z=2][y=1][x=2]", "label of the class table", "got 7"});
  check([](bb::SampleVolume& v) { v.dims = {0, 4, 3}; }, {"/labels", "dims > 0"});
  check([](bb::SampleVolume& v) { v.voxel_mm = -1; }, {"/@voxel_size_mm", "> 0"});
  check([](bb::SampleVolume& v) { v.origin_mm.y = INFINITY; }, {"/@origin_mm", "finite"});
  check([](bb::SampleVolume& v) { v.labels.pop_back(); }, {"/labels", "108 voxels"});
  check([](bb::SampleVolume& v) { v.classes[0] = "air"; }, {"class ids 1..255"});
  check([](bb::SampleVolume& v) { v.classes[2] = "compact"; }, {"unique class names"});
  check([](bb::SampleVolume& v) { v.segmentation_json = "{oops"; }, {"/segmentation_json", "JSON"});
  // A huge claim is refused from the dims alone (nothing the size of it is allocated).
  check([](bb::SampleVolume& v) { v.dims = {100000, 100000, 100000}; }, {"/labels", "memory budget"});
}

TEST(FormatsSample, BrokenFilesAreRejectedAndUntouched) {
  TempDir dir;
  bb::write_sample(dir / "s.h5", make_sample());
  const auto size = std::filesystem::file_size(dir / "s.h5");
  std::filesystem::copy_file(dir / "s.h5", dir / "t.h5");
  std::filesystem::resize_file(dir / "t.h5", size / 2);
  const std::string t = (dir / "t.h5").string();
  expect_rejected_unchanged(dir / "t.h5", [&] { bb::read_sample(t); }, {t + ": "});
  burrbench::test::write_text(dir / "n.h5", "NRRD0004\ntype: uint8\n");
  const std::string n = (dir / "n.h5").string();
  expect_rejected_unchanged(dir / "n.h5", [&] { bb::read_sample(n); }, {n, "an HDF5 file"});
  // A corrupted byte in the middle of the data: still one InputError, never a crash.
  std::string bytes = burrbench::test::file_bytes(dir / "s.h5");
  for (std::size_t i = bytes.size() / 3; i < bytes.size() / 3 + 64; ++i) bytes[i] = char(0xA5);
  burrbench::test::write_text(dir / "c.h5", bytes);
  try {
    bb::read_sample(dir / "c.h5");
  } catch (const burrbench::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("c.h5"), std::string::npos);
  }
  EXPECT_EQ(bytes, burrbench::test::file_bytes(dir / "c.h5"));
}

// Seeded byte corruption of our own files: HDF5 metadata checksums (1.8 format) and the
// validators turn every outcome into a valid volume or an InputError — never a crash.
TEST(FormatsSample, CorruptedFilesOnlyEverRaiseInputError) {
  TempDir dir;
  bb::write_sample(dir / "s.h5", make_sample());
  const std::string base = burrbench::test::file_bytes(dir / "s.h5");
  const int rejected = burrbench::test::count_rejected_corruptions(
      base, dir / "c.h5", 300, 4242, 4, false, [](const auto& p) { bb::read_sample(p); });
  EXPECT_GT(rejected, 100);
}
