#include "io/vtk_writer.hpp"

#include <gtest/gtest.h>

#include "temp_dir.hpp"
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

namespace fs = std::filesystem;
using mca::io::PointField;
using mca::io::write_pvd;
using mca::io::write_vtu;

using mca::test::slurp;
using mca::test::TempDir;

namespace {


bool has_tmp_file(const fs::path& dir) {
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".tmp") return true;
  return false;
}

std::string attribute(const std::string& element, const std::string& name) {
  const std::regex re("\\b" + name + "=\"([^\"]*)\"");
  std::smatch m;
  return std::regex_search(element, m, re) ? m[1].str() : std::string();
}

// A minimal reader for what write_vtu produces: the XML header up to the '_' marker, then the raw
// blocks, each a UInt64 byte count followed by the bytes.
struct ParsedVtu {
  std::string header;
  struct Array {
    std::string type;
    int components = 1;
    std::vector<char> bytes;
  };
  std::map<std::string, Array> arrays;

  template <class T>
  std::vector<T> values(const std::string& name) const {
    const auto& b = arrays.at(name).bytes;
    std::vector<T> v(b.size() / sizeof(T));
    std::memcpy(v.data(), b.data(), v.size() * sizeof(T));
    return v;
  }
};

ParsedVtu parse_vtu(const fs::path& path) {
  const std::string text = slurp(path);
  ParsedVtu out;
  const std::string marker = "<AppendedData encoding=\"raw\">";
  const auto appended = text.find(marker);
  EXPECT_NE(appended, std::string::npos);
  const auto underscore = text.find('_', appended + marker.size());
  EXPECT_NE(underscore, std::string::npos);
  out.header = text.substr(0, underscore);
  const std::size_t base = underscore + 1;

  std::uint64_t end_of_blocks = base;
  const std::regex element("<DataArray[^>]*/>");
  for (auto it = std::sregex_iterator(out.header.begin(), out.header.end(), element);
       it != std::sregex_iterator(); ++it) {
    const std::string e = it->str();
    EXPECT_EQ(attribute(e, "format"), "appended") << e;
    ParsedVtu::Array a;
    a.type = attribute(e, "type");
    const std::string nc = attribute(e, "NumberOfComponents");
    a.components = nc.empty() ? 1 : std::stoi(nc);
    const std::uint64_t offset = std::stoull(attribute(e, "offset"));
    std::uint64_t bytes = 0;
    EXPECT_LE(base + offset + sizeof bytes, text.size()) << e;
    std::memcpy(&bytes, text.data() + base + offset, sizeof bytes);
    EXPECT_LE(base + offset + sizeof bytes + bytes, text.size()) << e;
    const char* begin = text.data() + base + offset + sizeof bytes;
    a.bytes.assign(begin, begin + bytes);
    end_of_blocks = std::max<std::uint64_t>(end_of_blocks, base + offset + sizeof bytes + bytes);
    out.arrays[attribute(e, "Name")] = std::move(a);
  }
  EXPECT_EQ(text.substr(end_of_blocks), "\n  </AppendedData>\n</VTKFile>\n");
  return out;
}

struct Sample {
  static constexpr std::size_t n = 5;
  std::vector<float> xyz, velocity, damage;
  std::vector<std::int32_t> group;
  Sample() {
    for (std::size_t i = 0; i < n; ++i) {
      for (int c = 0; c < 3; ++c) {
        xyz.push_back(static_cast<float>(i) + 0.25f * static_cast<float>(c) - 1.5f);
        velocity.push_back(-0.125f * static_cast<float>(i * 3 + c) + 1e-7f);
      }
      damage.push_back(static_cast<float>(i) / 7.0f);
      group.push_back(static_cast<std::int32_t>(i % 2) - 1);
    }
  }
  std::vector<PointField> fields() const {
    return {{"velocity", 3, velocity.data(), nullptr},
            {"group", 1, nullptr, group.data()},
            {"damage", 1, damage.data(), nullptr}};
  }
};

}  // namespace

TEST(VtkWriter, PointsAndFieldsReadBack) {
  TempDir dir;
  const Sample s;
  const fs::path file = dir.path() / "frame.vtu";
  write_vtu(file, Sample::n, s.xyz.data(), s.fields());
  EXPECT_FALSE(has_tmp_file(dir.path()));

  const ParsedVtu p = parse_vtu(file);
  EXPECT_NE(p.header.find("type=\"UnstructuredGrid\""), std::string::npos);
  EXPECT_NE(p.header.find("header_type=\"UInt64\""), std::string::npos);
  EXPECT_NE(p.header.find("byte_order=\"LittleEndian\""), std::string::npos);
  EXPECT_NE(p.header.find("NumberOfPoints=\"5\" NumberOfCells=\"5\""), std::string::npos);

  ASSERT_EQ(p.arrays.count("Points"), 1u);
  EXPECT_EQ(p.arrays.at("Points").type, "Float32");
  EXPECT_EQ(p.arrays.at("Points").components, 3);
  EXPECT_EQ(p.arrays.at("Points").bytes.size(), Sample::n * 3 * sizeof(float));
  EXPECT_EQ(p.values<float>("Points"), s.xyz);

  EXPECT_EQ(p.arrays.at("velocity").type, "Float32");
  EXPECT_EQ(p.arrays.at("velocity").components, 3);
  EXPECT_EQ(p.values<float>("velocity"), s.velocity);
  EXPECT_EQ(p.arrays.at("group").type, "Int32");
  EXPECT_EQ(p.values<std::int32_t>("group"), s.group);
  EXPECT_EQ(p.values<float>("damage"), s.damage);

  EXPECT_EQ(p.values<std::int32_t>("connectivity"), (std::vector<std::int32_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(p.values<std::int32_t>("offsets"), (std::vector<std::int32_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(p.values<std::uint8_t>("types"), (std::vector<std::uint8_t>(5, 1)));  // VTK_VERTEX
}

TEST(VtkWriter, LinesFollowTheVertexCells) {
  TempDir dir;
  const Sample s;
  const std::vector<std::array<std::uint32_t, 2>> lines{{0, 1}, {3, 4}};
  const fs::path file = dir.path() / "frame_lines.vtu";
  write_vtu(file, Sample::n, s.xyz.data(), s.fields(), &lines);
  EXPECT_FALSE(has_tmp_file(dir.path()));

  const ParsedVtu p = parse_vtu(file);
  EXPECT_NE(p.header.find("NumberOfPoints=\"5\" NumberOfCells=\"7\""), std::string::npos);
  EXPECT_EQ(p.values<float>("Points"), s.xyz);
  EXPECT_EQ(p.values<float>("damage"), s.damage);
  EXPECT_EQ(p.values<std::int32_t>("connectivity"), (std::vector<std::int32_t>{0, 1, 2, 3, 4, 0, 1, 3, 4}));
  EXPECT_EQ(p.values<std::int32_t>("offsets"), (std::vector<std::int32_t>{1, 2, 3, 4, 5, 7, 9}));
  EXPECT_EQ(p.values<std::uint8_t>("types"), (std::vector<std::uint8_t>{1, 1, 1, 1, 1, 3, 3}));
}

TEST(VtkWriter, EmptyFrameIsValid) {
  TempDir dir;
  const fs::path file = dir.path() / "empty.vtu";
  write_vtu(file, 0, nullptr, {{"damage", 1, nullptr, nullptr}});
  const ParsedVtu p = parse_vtu(file);
  EXPECT_NE(p.header.find("NumberOfPoints=\"0\" NumberOfCells=\"0\""), std::string::npos);
  EXPECT_TRUE(p.arrays.at("Points").bytes.empty());
}

TEST(VtkWriter, RejectsBadFieldsAndLines) {
  TempDir dir;
  const Sample s;
  const fs::path file = dir.path() / "bad.vtu";
  EXPECT_THROW(write_vtu(file, Sample::n, s.xyz.data(), {{"both", 1, s.damage.data(), s.group.data()}}),
               std::invalid_argument);
  EXPECT_THROW(write_vtu(file, Sample::n, s.xyz.data(), {{"none", 1, nullptr, nullptr}}), std::invalid_argument);
  const std::vector<std::array<std::uint32_t, 2>> lines{{0, 5}};
  EXPECT_THROW(write_vtu(file, Sample::n, s.xyz.data(), {}, &lines), std::invalid_argument);
  EXPECT_FALSE(fs::exists(file));
  EXPECT_FALSE(has_tmp_file(dir.path()));
}

TEST(VtkWriter, TrianglesAndTheirValuesReadBack) {
  TempDir dir;
  const Sample s;
  const fs::path file = dir.path() / "surface.vtp";
  const std::vector<std::array<std::uint32_t, 3>> triangles{{0, 1, 2}, {2, 3, 4}};
  mca::io::write_vtp(file, Sample::n, s.xyz.data(), triangles, "fragment", {7, -1});
  const ParsedVtu p = parse_vtu(file);
  EXPECT_NE(p.header.find("<VTKFile type=\"PolyData\""), std::string::npos);
  EXPECT_NE(p.header.find("NumberOfPoints=\"5\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" "
                          "NumberOfPolys=\"2\""),
            std::string::npos);
  EXPECT_NE(p.header.find("<CellData>"), std::string::npos);
  EXPECT_EQ(p.values<float>("Points"), s.xyz);
  EXPECT_EQ(p.values<std::int64_t>("connectivity"), (std::vector<std::int64_t>{0, 1, 2, 2, 3, 4}));
  EXPECT_EQ(p.values<std::int64_t>("offsets"), (std::vector<std::int64_t>{3, 6}));
  EXPECT_EQ(p.values<std::int32_t>("fragment"), (std::vector<std::int32_t>{7, -1}));
  // An index past the points, or values not one a triangle, is refused before anything is written.
  const fs::path bad = dir.path() / "bad.vtp";
  EXPECT_THROW(mca::io::write_vtp(bad, Sample::n, s.xyz.data(), {{0, 1, 5}}, "fragment", {}), std::invalid_argument);
  EXPECT_THROW(mca::io::write_vtp(bad, Sample::n, s.xyz.data(), triangles, "fragment", {1}), std::invalid_argument);
  EXPECT_FALSE(fs::exists(bad));
}

TEST(VtkWriter, FieldNamesAreEscaped) {
  TempDir dir;
  const Sample s;
  const fs::path file = dir.path() / "names.vtu";
  write_vtu(file, Sample::n, s.xyz.data(), {{"a<b&\"c\"", 1, s.damage.data(), nullptr}});
  EXPECT_NE(slurp(file).find("Name=\"a&lt;b&amp;&quot;c&quot;\""), std::string::npos);
}

TEST(VtkWriter, PvdListsTimesAndFiles) {
  TempDir dir;
  const fs::path file = dir.path() / "series.pvd";
  write_pvd(file, {{0.0, "frame_0000.vtu"}, {1.5e-5, "frame_0001.vtu"}, {0.1, "frames/frame_0002.vtu"}});
  EXPECT_FALSE(has_tmp_file(dir.path()));
  const std::string text = slurp(file);
  EXPECT_NE(text.find("<VTKFile type=\"Collection\""), std::string::npos);

  const std::regex dataset("<DataSet[^>]*/>");
  std::vector<std::pair<double, std::string>> read;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), dataset); it != std::sregex_iterator(); ++it)
    read.emplace_back(std::stod(attribute(it->str(), "timestep")), attribute(it->str(), "file"));
  const std::vector<std::pair<double, std::string>> expected{
      {0.0, "frame_0000.vtu"}, {1.5e-5, "frame_0001.vtu"}, {0.1, "frames/frame_0002.vtu"}};
  EXPECT_EQ(read, expected);
}
