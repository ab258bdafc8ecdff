// End to end through the `mca` command: files written, JSON contents, resume, and bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>

#include <fmt/format.h>

#include "backend/backend.hpp"
#include "core/text.hpp"
#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "sim/engine.hpp"
#include "mesh_fixtures.hpp"
#include "shell.hpp"
#include "small_scene.hpp"

namespace mcaio = mca::io;

namespace {

namespace fs = std::filesystem;

using mca::test::Result;
using mca::test::run_mca;
using mca::test::run_mca_full_at;
using mca::test::shell;
using mca::test::read;
using mca::test::small_scene;

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("mca_cli_" + name);
  fs::remove_all(d);
  return d;
}

// An empty scene path (an unset shell variable: mca run "$SCENE") is refused, not taken for the built-in
// scene, which `mca run ""` used to run to the end (found by the hostile review).
TEST(Cli, AnEmptyScenePathIsRefused) {
  for (const char* cmd : {"info \"\"", "run \"\" --out /nonexistent-mca-test-dir"}) {
    SCOPED_TRACE(cmd);
    const Result r = run_mca(cmd);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("an empty scene path"), std::string::npos) << r.output;
  }
}

TEST(Cli, RunWritesFramesStatsAndSummary) {
  const fs::path d = fresh_dir("run");
  const fs::path scene = small_scene(d);
  const Result r = run_mca("run " + scene.string() + " --out " + (d / "out").string() + " --threads 2");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("done:"), std::string::npos) << r.output;
  const fs::path out = d / "out";
  for (const char* f : {"automata.pvd", "projectiles.pvd", "stats.csv", "summary.json", "scene.toml",
                        "frames/automata_000000.vtu", "frames/automata_000004.vtu"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_NE(e.path().extension(), ".tmp") << "left a temporary file: " << e.path();

  const auto j = nlohmann::json::parse(read(out / "summary.json"));
  EXPECT_EQ(j["scene"], "small");
  EXPECT_EQ(j["status"], "finished");
  EXPECT_EQ(j["automata"], 12 * 3 * 10);
  EXPECT_GT(j["broken_links"]["total"].get<int>(), 0);
  EXPECT_GT(j["automaton_steps_per_second"].get<double>(), 0);
  double mass = 0;
  std::int64_t automata = 0;
  for (const auto& f : j["fragments"]) {
    mass += f["mass"].get<double>();
    automata += f["automata"].get<std::int64_t>();
  }
  mass += j["unlisted_fragments"]["mass"].get<double>();
  automata += j["unlisted_fragments"]["automata"].get<std::int64_t>();
  EXPECT_NEAR(mass, j["total_mass"].get<double>(), 1e-9 * j["total_mass"].get<double>());
  EXPECT_EQ(automata, 360);
  EXPECT_EQ(j["fragments"].size(), std::min<std::size_t>(20, j["fragment_count"].get<std::size_t>()));
  EXPECT_EQ(j["fragments"].size() + j["unlisted_fragments"]["count"].get<std::size_t>(),
            j["fragment_count"].get<std::size_t>());
  // Heaviest first.
  for (std::size_t k = 1; k < j["fragments"].size(); ++k)
    EXPECT_GE(j["fragments"][k - 1]["mass"].get<double>(), j["fragments"][k]["mass"].get<double>());
  // The size bins hold every fragment and all the mass.
  std::int64_t binned = 0;
  double binned_mass = 0;
  for (const auto& b : j["fragment_sizes"]) {
    binned += b["fragments"].get<std::int64_t>();
    binned_mass += b["mass"].get<double>();
  }
  EXPECT_EQ(binned, j["fragment_count"].get<std::int64_t>());
  EXPECT_NEAR(binned_mass, j["total_mass"].get<double>(), 1e-9 * j["total_mass"].get<double>());
  // fragments.csv: a header and one row per fragment, heaviest first, the same masses and volumes d^3 each.
  std::istringstream fcsv(read(out / "fragments.csv"));
  std::string row;
  std::getline(fcsv, row);
  EXPECT_EQ(row.rfind("id,automata,mass,volume,centre_x", 0), 0u) << row;
  std::int64_t fragment_rows = 0, csv_automata = 0;
  double csv_mass = 0, csv_volume = 0;
  while (std::getline(fcsv, row)) {
    std::istringstream fields(row);
    std::string id, n, fm, fv;
    std::getline(fields, id, ',');
    std::getline(fields, n, ',');
    std::getline(fields, fm, ',');
    std::getline(fields, fv, ',');
    EXPECT_EQ(std::stoll(id), fragment_rows);
    csv_automata += std::stoll(n);
    csv_mass += std::stod(fm);
    csv_volume += std::stod(fv);
    ++fragment_rows;
  }
  EXPECT_EQ(fragment_rows, j["fragment_count"].get<std::int64_t>());
  EXPECT_EQ(csv_automata, 360);
  EXPECT_NEAR(csv_mass, j["total_mass"].get<double>(), 1e-6 * j["total_mass"].get<double>());
  EXPECT_NEAR(csv_volume, 360 * std::pow(j["spacing"].get<double>(), 3), 1e-6 * csv_volume);

  // stats.csv: a header and one row per frame (0..4), broken links never decrease.
  std::istringstream csv(read(out / "stats.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("frame,time,kinetic_energy", 0), 0u) << line;
  int rows = 0;
  long last_broken = -1;
  while (std::getline(csv, line)) {
    ++rows;
    std::vector<std::string> cells;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) cells.push_back(c);
    ASSERT_GE(cells.size(), 17u);
    const long broken = std::stol(cells[14]);
    EXPECT_GE(broken, last_broken);
    last_broken = broken;
  }
  EXPECT_EQ(rows, 5);
  EXPECT_NE(read(out / "automata.pvd").find("frames/automata_000004.vtu"), std::string::npos);
  EXPECT_EQ(read(out / "scene.toml").rfind("# Written by mca", 0), 0u);
  // A step count is not a key of the scene: the folder's scene.toml names it at its top, and the command
  // it gives repeats the run.
  const fs::path cut = d / "cut", again = d / "again";
  ASSERT_EQ(run_mca("run " + scene.string() + " --steps 37 --no-vtk -q --out " + cut.string()).code, 0);
  const std::string text = read(cut / "scene.toml");
  EXPECT_EQ(text.rfind("# This run: --steps 37 (", 0), 0u) << text;
  EXPECT_NE(text.find("`mca run scene.toml --steps 37` repeats it\n# Written by mca"), std::string::npos) << text;
  ASSERT_EQ(run_mca("run " + (cut / "scene.toml").string() + " --steps 37 --no-vtk -q --out " + again.string()).code, 0);
  EXPECT_EQ(nlohmann::json::parse(read(cut / "summary.json"))["state_hash"],
            nlohmann::json::parse(read(again / "summary.json"))["state_hash"]);
  EXPECT_EQ(nlohmann::json::parse(read(cut / "summary.json"))["steps"], 37);
}

TEST(Cli, ResumedRunEndsBitwiseEqualToAnUninterruptedOne) {
  const fs::path d = fresh_dir("resume");
  const fs::path scene = small_scene(d);
  const fs::path a = d / "a";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + a.string() + " -q").code, 0);
  // Build the interrupted run: frames 0..2 with a checkpoint at frame 2.
  const fs::path c = d / "c2";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + c.string() + " -q --checkpoint-every 2").code, 0);
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(c / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  ASSERT_GE(cks.size(), 2u);
  fs::remove(cks.back());  // the newest (frame 4) is "lost": resume starts from frame 2
  fs::remove(c / "summary.json");
  const Result r = run_mca("resume " + c.string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto ja = nlohmann::json::parse(read(a / "summary.json"));
  const auto jc = nlohmann::json::parse(read(c / "summary.json"));
  EXPECT_EQ(ja["state_hash"], jc["state_hash"]);
  EXPECT_EQ(ja["steps"], jc["steps"]);
  EXPECT_EQ(read(a / "stats.csv"), read(c / "stats.csv"));
}

// A run checkpointed on the CPU backend continues on the CUDA backend's algorithm (its host emulation) and
// ends with the bits of an uninterrupted CPU run; --backend names a bad choice and a missing GPU clearly.
TEST(Cli, ARunCheckpointedOnOneBackendResumesOnAnotherWithTheSameBits) {
  const fs::path d = fresh_dir("resume_backend");
  const fs::path scene = small_scene(d);
  const fs::path a = d / "a";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + a.string() + " -q --backend cpu").code, 0);
  const fs::path c = d / "c";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + c.string() + " -q --checkpoint-every 2 --backend cpu").code, 0);
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(c / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  ASSERT_GE(cks.size(), 2u);
  fs::remove(cks.back());
  fs::remove(c / "summary.json");
  const Result r = run_mca("resume " + c.string() + " -q --backend cuda-emulation");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto ja = nlohmann::json::parse(read(a / "summary.json"));
  const auto jc = nlohmann::json::parse(read(c / "summary.json"));
  EXPECT_EQ(jc["backend"], "cuda-emulation");
  EXPECT_EQ(jc["steps_run_on"], "one core");
  EXPECT_EQ(ja["steps_run_on"], fmt::format("{} thread{}", ja["threads"].get<int>(), ja["threads"] == 1 ? "" : "s"));
  EXPECT_EQ(ja["state_hash"], jc["state_hash"]);
  EXPECT_EQ(read(a / "stats.csv"), read(c / "stats.csv"));
  // --backend holds for its resume only: a plain resume after it runs where the folder's scene.toml says
  // (cpu, from the run's --backend), though the checkpoints that resume wrote name cuda-emulation. Before, the
  // override stuck to every later resume, which ran on one core without a word (the hostile review of
  // 2026-12-06).
  // (From the last checkpoint, which the cuda-emulation resume wrote: no step is left, and the outputs are
  // finished again on the backend the resume takes.)
  for (const char* again : {"", " --backend cuda-emulation"}) {
    SCOPED_TRACE(again);
    fs::remove(c / "summary.json");
    const Result plain = run_mca("resume " + c.string() + " -q" + again);
    ASSERT_EQ(plain.code, 0) << plain.output;
    const auto jp = nlohmann::json::parse(read(c / "summary.json"));
    EXPECT_EQ(jp["backend"].get<std::string>().rfind(*again ? "cuda-emulation" : "cpu", 0), 0u) << jp["backend"];
    EXPECT_EQ(ja["state_hash"], jp["state_hash"]);
  }

  const Result bad = run_mca("run " + scene.string() + " --out " + (d / "x").string() + " -q --backend gpu");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.output.find("--backend 'gpu': give auto (the default), cpu, cuda or cuda-emulation"), std::string::npos)
      << bad.output;
  EXPECT_FALSE(fs::exists(d / "x" / "summary.json"));
  std::string why;
  if (mca::cuda_device(&why).empty()) {
    const Result no_gpu = run_mca("run " + scene.string() + " --out " + (d / "y").string() + " -q --backend cuda");
    EXPECT_EQ(no_gpu.code, 2);
    EXPECT_NE(no_gpu.output.find("solver.backend = \"cuda\" (or --backend cuda): " + why), std::string::npos)
        << no_gpu.output;
    // A folder whose scene.toml says cuda, resumed where there is no GPU: the message names scene.toml, not
    // the checkpoint's embedded scene (which says where the session that wrote it ran), and the fix.
    std::string text = read(c / "scene.toml");
    const std::size_t at = text.find("backend = \"cpu\"");
    ASSERT_NE(at, std::string::npos) << text;
    std::ofstream(c / "scene.toml") << text.replace(at, 15, "backend = \"cuda\"");
    const Result resumed = run_mca("resume " + c.string() + " -q");
    EXPECT_EQ(resumed.code, 2) << resumed.output;
    EXPECT_NE(resumed.output.find((c / "scene.toml").string() + ": solver.backend = \"cuda\", where this resume "
                                  "would run: " + why),
              std::string::npos)
        << resumed.output;
    EXPECT_NE(resumed.output.find("mca resume " + c.string() + " --backend cpu"), std::string::npos) << resumed.output;
  }
}

// A new run replaces an earlier run's files in its folder, and nothing else: names of the run's forms only
// (frames/automata_000003.vtu, not frames/automata_mine.vtu). A folder that holds files of the run's names
// but no run of mca (a user's summary.json) is refused as it is; a user's other files stay.
TEST(Cli, ARunReplacesOnlyARunsFilesAndRefusesAFolderOfOthers) {
  const fs::path d = fresh_dir("foreign_files");
  const fs::path scene = small_scene(d);
  const fs::path out = d / "out";
  const std::vector<std::string> theirs = {"notes.txt", "frames/automata_mine.vtu", "frames/readme.txt",
                                           "checkpoints/frame_final.mcack", "render/frame_cover.png",
                                           "fragments/fragment_design.ply", "surface/surface_cad.obj"};
  for (const auto& f : theirs) {
    fs::create_directories((out / f).parent_path());
    std::ofstream(out / f) << "a user's " << f << "\n";
  }
  std::ofstream(out / "summary.json") << "{\"theirs\": true}\n";
  std::ofstream(out / "frames" / "automata_000001.vtu") << "theirs\n";
  const Result refused = run_mca("run " + scene.string() + " --out " + out.string() + " -q");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find(out.string() + " holds summary.json, frames/automata_000001.vtu, of the names a run "
                                "of mca writes, but no run of mca (its scene.toml is missing)"),
            std::string::npos)
      << refused.output;
  EXPECT_EQ(read(out / "summary.json"), "{\"theirs\": true}\n");
  EXPECT_FALSE(fs::exists(out / "scene.toml"));
  // A scene.toml of the user's own is not a run's either.
  std::ofstream(out / "scene.toml") << "name = \"theirs\"\n";
  EXPECT_NE(run_mca("run " + scene.string() + " --out " + out.string() + " -q").output.find("was not written by mca"),
            std::string::npos);
  fs::remove(out / "summary.json");
  fs::remove(out / "scene.toml");
  fs::remove(out / "frames" / "automata_000001.vtu");
  // The run writes beside the user's files, then a second run replaces the first one's files.
  for (int k = 0; k < 2; ++k) {
    const Result r = run_mca("run " + scene.string() + " --out " + out.string() + " -q --checkpoint-every 1");
    ASSERT_EQ(r.code, 0) << r.output;
  }
  for (const auto& f : theirs) EXPECT_EQ(read(out / f), "a user's " + f + "\n") << f;
  EXPECT_TRUE(fs::exists(out / "frames" / "automata_000004.vtu"));
  EXPECT_EQ(nlohmann::json::parse(read(out / "summary.json"))["status"], "finished");
}

// A new run in the folder of a run that did not finish (checkpoints, and no summary of a finished run:
// interrupted, killed, stopped by a full disk) would remove the checkpoints that continue it: it is
// refused, naming mca resume and how to start afresh.
TEST(Cli, ANewRunDoesNotReplaceAnUnfinishedOne) {
  const fs::path d = fresh_dir("unfinished");
  const fs::path scene = small_scene(d);
  const fs::path out = d / "out";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + out.string() + " -q --checkpoint-every 2").code, 0);
  const std::string hash = nlohmann::json::parse(read(out / "summary.json"))["state_hash"];
  fs::remove(out / "checkpoints" / "frame_000004.mcack");
  for (const std::string& summary : {std::string("interrupted"), std::string()}) {
    if (summary.empty()) fs::remove(out / "summary.json");  // killed: none
    else std::ofstream(out / "summary.json") << "{\"status\": \"" << summary << "\"}\n";
    const Result r = run_mca("run " + scene.string() + " --out " + out.string() + " -q --steps 3");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(out.string() + " holds a run that did not finish (its newest checkpoint: "
                            "frame_000002.mcack); continue it with: mca resume " + out.string() +
                            ". To start it afresh instead, remove its checkpoints first (rm -r " +
                            (out / "checkpoints").string() + "), or give another --out folder"),
              std::string::npos)
        << r.output;
    EXPECT_TRUE(fs::exists(out / "checkpoints" / "frame_000002.mcack"));
  }
  const Result resumed = run_mca("resume " + out.string() + " -q");
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(nlohmann::json::parse(read(out / "summary.json"))["state_hash"], hash);
  // Finished now: a new run replaces it.
  EXPECT_EQ(run_mca("run " + scene.string() + " --out " + out.string() + " -q --steps 3").code, 0);
}

// Resuming a run that has finished says so (it used to print only "resuming" and "0 steps"), exits 0 and
// leaves its result as it was.
TEST(Cli, ResumingAFinishedRunSaysNoStepIsLeft) {
  const fs::path d = fresh_dir("resume_finished");
  const fs::path out = d / "out";
  ASSERT_EQ(run_mca("run " + small_scene(d).string() + " --out " + out.string() + " -q --checkpoint-every 1").code, 0);
  const auto before = nlohmann::json::parse(read(out / "summary.json"));
  const Result r = run_mca("resume " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("no step is left to run"), std::string::npos) << r.output;
  const auto after = nlohmann::json::parse(read(out / "summary.json"));
  EXPECT_EQ(before["state_hash"], after["state_hash"]);
  EXPECT_EQ(before["steps"], after["steps"]);
  // A finished run whose newest checkpoint is before its end: the frames after it are run again, and the
  // resume says so (it said nothing; the hostile review of 2026-12-06).
  const fs::path early = d / "early";
  ASSERT_EQ(run_mca("run " + small_scene(d).string() + " --out " + early.string() + " -q --checkpoint-every 3").code, 0);
  const auto first = nlohmann::json::parse(read(early / "summary.json"));
  const Result again = run_mca("resume " + early.string());
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("mca: the run in " + early.string() + " has finished (its summary.json says so), and "
                              "its newest checkpoint is of frame 3 (the run ends at frame 4): the resume runs the "
                              "frames after it again"),
            std::string::npos)
      << again.output;
  EXPECT_EQ(first["state_hash"], nlohmann::json::parse(read(early / "summary.json"))["state_hash"]);
}

TEST(Cli, InfoReportsTheModel) {
  const fs::path d = fresh_dir("info");
  const Result r = run_mca("info " + small_scene(d).string() + " --json");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["automata"], 360);
  EXPECT_GT(j["links"].get<int>(), 0);
  EXPECT_GT(j["time_step"].get<double>(), 0);
  EXPECT_GT(j["steps_per_frame"].get<int>(), 0);
  EXPECT_GT(j["memory_bytes"].get<double>(), 0);
  EXPECT_EQ(j["lattice"], "random");
  EXPECT_NEAR(j["link_bending"].get<double>(), 0.1, 1e-7);
  const Result text = run_mca("info");
  EXPECT_EQ(text.code, 0);
  EXPECT_NE(text.output.find("4800"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("lattice          random (link_bending 0.1)"), std::string::npos) << text.output;
}

// Far from the origin a step loses slow motion (docs/model-notes.md, "Far from the origin"): a scene that
// reaches beyond 1 km gets a note in mca info (text and JSON) and mca run with the resolution there and the
// slowest speed a step moves; within 1 km none.
TEST(Cli, AFarSceneGetsANoteOfWhatItsPositionsResolve) {
  const fs::path d = fresh_dir("far_note");
  const fs::path near = small_scene(d, "", "near");
  std::string text = read(near);
  for (const char* key : {"position = [0, 0, 0.25]", "position = [0, -0.17, 0.25]"}) {
    const std::size_t at = text.find(key);
    ASSERT_NE(at, std::string::npos) << key;
    text.replace(at, std::strlen("position = [0"), "position = [700000");
  }
  text += "\n";
  const fs::path far = d / "far.toml";
  std::ofstream(far) << text;
  const Result info = run_mca("info " + far.string());
  ASSERT_EQ(info.code, 0) << info.output;
  EXPECT_NE(info.output.find("note             the scene reaches 700000 m from the origin, where its double positions "
                             "resolve 1.2e-10 m: a step of "),
            std::string::npos)
      << info.output;
  EXPECT_NE(info.output.find("move its objects, projectiles and ground there"), std::string::npos) << info.output;
  const Result json = run_mca("info " + far.string() + " --json");
  ASSERT_EQ(json.code, 0) << json.output;
  EXPECT_TRUE(nlohmann::json::parse(json.output).contains("far_from_origin"));
  const Result run = run_mca("run " + far.string() + " --steps 2 --no-vtk --out " + (d / "out").string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("note: the scene reaches 700000 m"), std::string::npos) << run.output;
  const Result near_info = run_mca("info " + near.string() + " --json");
  ASSERT_EQ(near_info.code, 0) << near_info.output;
  EXPECT_FALSE(nlohmann::json::parse(near_info.output).contains("far_from_origin"));
}

// A mesh object whose mass misses its mesh's gets a note in mca info (text and JSON) and mca run: a volume
// fill of few automata (a sphere of radius 0.2 m at a spacing of 0.15 m), a shell
// thicker than the body it bounds (a cube of 1 m in 12 triangles: 0.52 m thick, three times the solid's
// mass). Neither was said (a hostile review, 2026-12-06). A fill of many automata gets none.
TEST(Cli, AMeshObjectWhoseMassMissesItsMeshsGetsANote) {
  const fs::path d = fresh_dir("mass_note");
  fs::create_directories(d);
  mca::test::write_mesh_file(d / "ball.off", mca::test::sphere_mesh(0.2, 3));
  mca::test::write_mesh_file(d / "cube.off", mca::test::cube_mesh(0.5));
  const auto scene = [&](const std::string& name, const std::string& object) {
    std::ofstream(d / (name + ".toml")) << "[solver]\nspacing = 0.15\ngravity = [0, 0, 0]\n[[object]]\nshape = \"mesh\"\n"
                                        << object;
    return (d / (name + ".toml")).string();
  };
  const Result fill = run_mca("info " + scene("fill", "mesh = \"ball.off\"\n"));
  ASSERT_EQ(fill.code, 0) << fill.output;
  EXPECT_NE(fill.output.find("note             object 'object': its "), std::string::npos) << fill.output;
  EXPECT_NE(fill.output.find("the spacing is coarse for it, and its mass is off by as much; a spacing of about"),
            std::string::npos)
      << fill.output;
  const Result shell = run_mca("info " + scene("shell", "mesh = \"cube.off\"\nfill = \"surface\"\n"));
  ASSERT_EQ(shell.code, 0) << shell.output;
  EXPECT_NE(shell.output.find("more than the solid it bounds would (2400 kg): the shell is thicker than the body"),
            std::string::npos)
      << shell.output;
  const Result json = run_mca("info " + (d / "shell.toml").string() + " --json");
  ASSERT_EQ(json.code, 0) << json.output;
  EXPECT_EQ(nlohmann::json::parse(json.output)["mesh_mass_notes"].size(), 1u);
  const Result run = run_mca("run " + (d / "fill.toml").string() + " --steps 2 --no-vtk --out " + (d / "out").string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("note: object 'object': its "), std::string::npos) << run.output;
  std::ofstream(d / "fine.toml") << "[solver]\nspacing = 0.02\ngravity = [0, 0, 0]\n[[object]]\nshape = \"mesh\"\n"
                                    "mesh = \"ball.off\"\n";
  const Result fine = run_mca("info " + (d / "fine.toml").string() + " --json");
  ASSERT_EQ(fine.code, 0) << fine.output;
  EXPECT_FALSE(nlohmann::json::parse(fine.output).contains("mesh_mass_notes"));
}

// A ball that sets a critical step far shorter than the objects' own (a ball of 1 um beside a wall: a
// step of 9e-11 s, 95 million steps for 10 ms) gets a note in mca info and mca run saying so; the run did
// not say why it was slow (a hostile review, 2026-12-06).
TEST(Cli, ABallThatSetsAFarShorterStepGetsANote) {
  const fs::path d = fresh_dir("step_note");
  fs::create_directories(d);
  std::ofstream(d / "tiny.toml") << "[solver]\nspacing = 0.05\nlattice = \"random\"\ngravity = [0, 0, 0]\n"
                                    "[output]\nduration = 0.01\nvtk = false\n[[object]]\nshape = \"box\"\n"
                                    "size = [0.6, 0.2, 0.6]\n[[projectile]]\nradius = 1e-6\n"
                                    "position = [0, -0.1002, 0]\nvelocity = [0, 10, 0]\n";
  const Result info = run_mca("info " + (d / "tiny.toml").string());
  ASSERT_EQ(info.code, 0) << info.output;
  EXPECT_NE(info.output.find("note             the critical time step (1.83e-10 s) is set by projectile 'ball' (mass "
                             "3.29e-14 kg) against the automata it can touch, 19"),
            std::string::npos)
      << info.output;
  EXPECT_NE(info.output.find("times shorter than the objects' own (3.62e-06 s)"), std::string::npos) << info.output;
  const Result run = run_mca("run " + (d / "tiny.toml").string() + " --steps 1 --out " + (d / "out").string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("note: the critical time step (1.83e-10 s) is set by projectile 'ball'"), std::string::npos)
      << run.output;
  const Result plain = run_mca("info --json");
  ASSERT_EQ(plain.code, 0) << plain.output;
  EXPECT_FALSE(nlohmann::json::parse(plain.output).contains("step_note"));
}

// Frames shorter than the automatic step make it, one step a frame: mca info and mca run say so, how many
// times shorter, and the frame_rate that gives frames of ten steps (the step was cut ten-fold, or a million-
// fold at frame_rate = 1e12, while the time step's line named solver.safety: a hostile review).
TEST(Cli, FramesShorterThanTheAutomaticStepGetANote) {
  const fs::path d = fresh_dir("frame_step_note");
  fs::create_directories(d);
  const std::string scene = "[solver]\nspacing = 0.05\nlattice = \"cubic\"\ngravity = [0, 0, 0]\n[output]\n"
                            "duration = 1e-4\nvtk = false\nframe_rate = {}\n[[object]]\nshape = \"box\"\n"
                            "size = [0.2, 0.2, 0.2]\n";
  std::ofstream(d / "short.toml") << fmt::format(fmt::runtime(scene), "1e7");
  const Result info = run_mca("info " + (d / "short.toml").string() + " --json");
  ASSERT_EQ(info.code, 0) << info.output;
  const auto j = nlohmann::json::parse(info.output);
  ASSERT_TRUE(j.contains("frame_step_note")) << info.output;
  const std::string note = j["frame_step_note"];
  EXPECT_NE(note.find("output.frame_rate = 1e+07 asks for frames of 1e-07 s, shorter than the automatic time step"),
            std::string::npos) << note;
  EXPECT_DOUBLE_EQ(j["time_step"].get<double>(), static_cast<double>(1e-7f));
  const Result text = run_mca("info " + (d / "short.toml").string());
  EXPECT_NE(text.output.find("one step a frame of output.frame_rate = 1e+07"), std::string::npos) << text.output;
  const Result run = run_mca("run " + (d / "short.toml").string() + " --steps 1 --out " + (d / "out").string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("note: output.frame_rate = 1e+07 asks for frames"), std::string::npos) << run.output;
  // The frame_rate it names gives frames of ten steps or more, each within a tenth of the automatic step,
  // and no note.
  const std::size_t at = note.find("a frame_rate of at most ") + 24;
  const std::string rate = note.substr(at, note.find(' ', at) - at);
  std::ofstream(d / "ten.toml") << fmt::format(fmt::runtime(scene), rate);
  const Result ten = run_mca("info " + (d / "ten.toml").string() + " --json");
  ASSERT_EQ(ten.code, 0) << ten.output;
  const auto t = nlohmann::json::parse(ten.output);
  EXPECT_FALSE(t.contains("frame_step_note")) << ten.output;
  EXPECT_GE(t["steps_per_frame"].get<int>(), 10);
  EXPECT_GE(t["time_step"].get<double>(), 0.9 * 0.5 * t["critical_time_step"].get<double>());
}

// A material that raises its strength (or a stress_coefficient that raises every one) and keeps its base's
// fracture_strain breaks by displacement first: weaker than its strength says, its softening cut short,
// without a word (a hostile review, 2026-12-06: concrete at 9 MPa broke more links than at 3 MPa). mca info
// and mca run name it and the fracture_strain that gives the stress criterion back; the built-in materials
// and a material whose strains are equal get no note.
TEST(Cli, AMaterialThatBreaksByDisplacementBeforeItsStrengthGetsANote) {
  const fs::path d = fresh_dir("strain_note");
  fs::create_directories(d);
  const auto scene = [&](const std::string& name, const std::string& material, const std::string& solver = "") {
    std::ofstream(d / (name + ".toml")) << "[solver]\nspacing = 0.05\n" << solver << "[output]\nduration = 0.001\n"
                                        << "[[material]]\nname = \"strong\"\nbase = \"concrete\"\n" << material
                                        << "[[object]]\nsize = [0.3, 0.3, 0.3]\nmaterial = \"strong\"\n";
    return (d / (name + ".toml")).string();
  };
  const Result strong = run_mca("info " + scene("strong", "tensile_strength = 9e6\n"));
  ASSERT_EQ(strong.code, 0) << strong.output;
  EXPECT_NE(strong.output.find("note             material \"strong\": its links reach fracture_strain = 0.00015 "
                               "before the strain at which the stress criterion ends them in tension "
                               "(tensile_strength / youngs_modulus = 0.0003): they break by displacement, at about "
                               "4.5 MPa instead of 9 MPa; for the stress criterion to govern, set fracture_strain = "
                               "0.00045 in its [[material]] (1.5 times that strain, the rule the built-in materials "
                               "follow at stress_coefficient 1)"),
            std::string::npos)
      << strong.output;
  const Result soft = run_mca("info " + scene("soft", "fracture_energy = 100\n", "stress_coefficient = 2\n") + " --json");
  ASSERT_EQ(soft.code, 0) << soft.output;
  const auto notes = nlohmann::json::parse(soft.output)["strain_limit_notes"];
  ASSERT_EQ(notes.size(), 1u) << soft.output;
  EXPECT_NE(notes[0].get<std::string>().find("(solver.stress_coefficient 2 x tensile_strength / youngs_modulus = "
                                             "0.0002, both times the softening's factor): they break by displacement, "
                                             "before their softening has taken fracture_energy"),
            std::string::npos)
      << notes[0];
  const Result run = run_mca("run " + (d / "strong.toml").string() + " --steps 1 --no-vtk --out " + (d / "out").string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("note: material \"strong\": its links reach fracture_strain"), std::string::npos)
      << run.output;
  for (const std::string& fine : {std::string("tensile_strength = 9e6\nfracture_strain = 4.5e-4\n"),
                                  std::string("tensile_strength = 4.5e6\n"), std::string()}) {
    const Result r = run_mca("info " + scene("fine", fine) + " --json");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_FALSE(nlohmann::json::parse(r.output).contains("strain_limit_notes")) << fine;
  }
  const Result plain = run_mca("info --json");
  ASSERT_EQ(plain.code, 0) << plain.output;
  EXPECT_FALSE(nlohmann::json::parse(plain.output).contains("strain_limit_notes"));
}

// Keys that did nothing, or advice that could not be taken, said so only by silence (a hostile review of
// meshes, 2026-12-06): output.surface_format = "obj" without output.surface gets a note; an angle of 1e300
// degrees is refused; an object too small for any spacing mca takes is told to grow, not to take a spacing
// of 1e-12 m (which solver.spacing refuses); mca info's mesh counts read "1 hole", not "1 holes".
TEST(Cli, KeysThatDoNothingAndAdviceThatCannotBeTakenAreNamed) {
  const fs::path d = fresh_dir("inert_keys");
  fs::create_directories(d);
  const std::string box = "[[object]]\nshape = \"box\"\nsize = [0.2, 0.2, 0.2]\nposition = [0, 0, 0.2]\n";
  std::ofstream(d / "obj.toml") << "[output]\nsurface_format = \"obj\"\nvtk = false\n" << box;
  const Result info = run_mca("info " + (d / "obj.toml").string());
  ASSERT_EQ(info.code, 0) << info.output;
  EXPECT_NE(info.output.find("note             output.surface_format = \"obj\" writes nothing: the surface outputs "
                             "are the triangles of mesh objects, and the scene has none"),
            std::string::npos)
      << info.output;
  const Result json = run_mca("info " + (d / "obj.toml").string() + " --json");
  ASSERT_EQ(json.code, 0) << json.output;
  EXPECT_TRUE(nlohmann::json::parse(json.output).contains("surface_format_note")) << json.output;
  const Result run = run_mca("run " + (d / "obj.toml").string() + " --steps 1 --out " + (d / "out").string());
  ASSERT_EQ(run.code, 0) << run.output;
  EXPECT_NE(run.output.find("note: output.surface_format = \"obj\" writes nothing"), std::string::npos) << run.output;
  // A resumed run says its notes again (its log may be the only one read).
  const fs::path cut = d / "cut";
  std::ofstream(d / "frames.toml") << "[output]\nsurface_format = \"obj\"\nvtk = false\nframe_rate = 1000\n"
                                      "duration = 0.003\n"
                                   << box;
  ASSERT_EQ(run_mca("run " + (d / "frames.toml").string() + " --checkpoint-every 1 -q --out " + cut.string()).code, 0);
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(cut / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  ASSERT_GE(cks.size(), 2u);
  fs::remove(cks.back());
  const Result resumed = run_mca("resume " + cut.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_NE(resumed.output.find("note: output.surface_format = \"obj\" writes nothing"), std::string::npos)
      << resumed.output;
  const Result plain = run_mca("info --json");
  ASSERT_EQ(plain.code, 0) << plain.output;
  EXPECT_FALSE(nlohmann::json::parse(plain.output).contains("surface_format_note"));

  std::ofstream(d / "turns.toml") << box << "rotation = [1e300, 0, 0]\n";
  const Result turns = run_mca("info " + (d / "turns.toml").string());
  EXPECT_EQ(turns.code, 2) << turns.output;
  EXPECT_NE(turns.output.find("object[0].rotation = [1e300, 0, 0] has an angle of more than 1e6 degrees"),
            std::string::npos)
      << turns.output;
  std::ofstream(d / "ok_turns.toml") << box << "rotation = [720, -45, 1e6]\n";
  EXPECT_EQ(run_mca("info " + (d / "ok_turns.toml").string()).code, 0);

  // A box without its lid in surface mode: its counts in the singular where they are one.
  std::ofstream(d / "lidless.off") << "OFF\n8 10 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
                                      "3 0 2 1\n3 0 3 2\n3 0 1 5\n3 0 5 4\n3 1 2 6\n3 1 6 5\n3 2 3 7\n3 2 7 6\n"
                                      "3 3 0 4\n3 3 4 7\n";
  std::ofstream(d / "lidless.toml") << "[[object]]\nshape = \"mesh\"\nmesh = \"lidless.off\"\nfill = \"surface\"\n"
                                       "fit_size = 0.3\nposition = [0, 0, 0.3]\n";
  const Result lidless = run_mca("info " + (d / "lidless.toml").string());
  ASSERT_EQ(lidless.code, 0) << lidless.output;
  EXPECT_NE(lidless.output.find("surface        4 boundary edges in 1 hole, 0 non-manifold edges, 0 degenerate faces"),
            std::string::npos)
      << lidless.output;
  {
    std::string twice = read(d / "lidless.off");
    twice.replace(twice.find("8 10 0"), 6, "8 11 0");
    std::ofstream(d / "lidless.off") << twice << "3 0 2 1\n";  // one triangle given twice
  }
  const Result repeated = run_mca("info " + (d / "lidless.toml").string());
  ASSERT_EQ(repeated.code, 0) << repeated.output;
  EXPECT_NE(repeated.output.find("; 1 repeated triangle left out"), std::string::npos) << repeated.output;
  // With a mesh object, the note says which key writes its surface.
  std::ofstream(d / "lidless_obj.toml") << "[output]\nsurface_format = \"obj\"\n" << read(d / "lidless.toml");
  const Result obj_mesh = run_mca("info " + (d / "lidless_obj.toml").string());
  ASSERT_EQ(obj_mesh.code, 0) << obj_mesh.output;
  EXPECT_NE(obj_mesh.output.find("output.surface_format = \"obj\" writes nothing: output.surface is false (set "
                                 "surface = true"),
            std::string::npos)
      << obj_mesh.output;

  std::ofstream(d / "speck.toml") << "[[object]]\nshape = \"box\"\nsize = [1e-12, 1e-12, 1e-12]\n";
  const Result speck = run_mca("info " + (d / "speck.toml").string());
  EXPECT_EQ(speck.code, 2) << speck.output;
  EXPECT_NE(speck.output.find("no spacing fits it: the least spacing this scene's materials take (1.17e-08 m: below "
                              "it an automaton's mass or moment of inertia, rho d^5 / 6, leaves the range of float32"),
            std::string::npos)
      << speck.output;
  EXPECT_NE(speck.output.find("is more than twice its thinnest side; make the object larger"), std::string::npos) << speck.output;
  // Its thinnest side decides, whichever side is named first (a cylinder 6e-9 m long and 3e-9 m across was
  // told a spacing its diameter then refused).
  std::ofstream(d / "needle.toml") << "[[object]]\nshape = \"cylinder\"\nradius = 1.5e-9\nheight = 6e-9\n";
  const Result needle = run_mca("info " + (d / "needle.toml").string());
  EXPECT_EQ(needle.code, 2) << needle.output;
  EXPECT_NE(needle.output.find("no spacing fits it"), std::string::npos) << needle.output;
  std::ofstream(d / "grain.toml") << "[[object]]\nshape = \"box\"\nsize = [1e-8, 1e-8, 1e-8]\n";
  const Result grain = run_mca("info " + (d / "grain.toml").string());
  EXPECT_EQ(grain.code, 2) << grain.output;
  EXPECT_NE(grain.output.find("decrease solver.spacing (to 1.17e-08 m; 10,000 automata would take a spacing of "
                              "4.64e-10 m, less than the least spacing this scene's materials take (1.17e-08 m"),
            std::string::npos)
      << grain.output;
  EXPECT_NE(grain.output.find("scale the objects up (object.scale or fit_size for a mesh, the sizes of a shape)"),
            std::string::npos)
      << grain.output;
  // The spacing it names is one the scene takes: followed, the box builds.
  std::ofstream(d / "grain_followed.toml") << "[solver]\nspacing = 1.17e-8\n"
                                           << "[[object]]\nshape = \"box\"\nsize = [1e-8, 1e-8, 1e-8]\n";
  const Result followed = run_mca("info " + (d / "grain_followed.toml").string());
  EXPECT_EQ(followed.output.find("float32"), std::string::npos) << followed.output;
  EXPECT_EQ(followed.output.find("half the spacing"), std::string::npos) << followed.output;
  // A target that would take a spacing past them is named so, with the count that fits, which builds.
  std::ofstream(d / "far_target.toml") << "[solver]\ntarget_automata = 1000000\n[[object]]\nshape = \"sphere\"\n"
                                          "radius = 1.5e-7\n";
  const Result target = run_mca("info " + (d / "far_target.toml").string());
  EXPECT_EQ(target.code, 2) << target.output;
  EXPECT_NE(target.output.find("solver.target_automata = 1000000 takes a spacing of "), std::string::npos) << target.output;
  EXPECT_NE(target.output.find(" m, less than the least spacing this scene's materials take (1.17e-08 m"),
            std::string::npos)
      << target.output;
  const std::size_t at = target.output.find("or ask for fewer automata (about ");
  ASSERT_NE(at, std::string::npos) << target.output;
  const long fewer = std::lround(std::stod(target.output.substr(at + 33)));
  std::ofstream(d / "far_target.toml") << "[solver]\ntarget_automata = " << fewer << "\n[[object]]\nshape = \"sphere\"\n"
                                          "radius = 1.5e-7\n[output]\nframe_rate = 1e7\nduration = 1e-7\n";
  const Result fewer_run = run_mca("info " + (d / "far_target.toml").string());
  EXPECT_EQ(fewer_run.code, 0) << fewer_run.output;
  // Too large for memory at any spacing the materials take: no spacing, and no memory, is advised.
  std::ofstream(d / "huge.toml") << "[[object]]\nshape = \"box\"\nsize = [1e12, 1e12, 1e12]\n";
  const Result huge = run_mca("info " + (d / "huge.toml").string());
  EXPECT_EQ(huge.code, 2) << huge.output;
  EXPECT_NE(huge.output.find("no spacing makes it fit: it would take 5.85e+09 m, more than the largest spacing this "
                             "scene's materials take (1.15e+07 m"),
            std::string::npos)
      << huge.output;
  EXPECT_EQ(huge.output.find("raise solver.max_memory_gb"), std::string::npos) << huge.output;
  // A spacing past them given as such: the float32 refusal names the range of the material's density.
  std::ofstream(d / "coarse.toml") << "[solver]\nspacing = 2e7\n[[object]]\nshape = \"box\"\n"
                                      "size = [1e8, 1e8, 1e8]\n";
  const Result coarse = run_mca("info " + (d / "coarse.toml").string());
  EXPECT_EQ(coarse.code, 2) << coarse.output;
  EXPECT_NE(coarse.output.find("at this density the spacing is safe from 1.17e-08 to 1.15e+07 m"), std::string::npos)
      << coarse.output;
}

TEST(Cli, BadInputFailsWithAClearMessage) {
  const fs::path d = fresh_dir("bad");
  // Missing scene file: names the file.
  Result r = run_mca("run " + (d / "nope.toml").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("nope.toml"), std::string::npos) << r.output;
  // Unknown key: did-you-mean and the line.
  fs::create_directories(d);
  std::ofstream(d / "typo.toml") << "[solver]\nspacnig = 0.05\n[[object]]\nsize = [1, 1, 1]\n";
  r = run_mca("run " + (d / "typo.toml").string() + " --out " + (d / "o").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("spacing"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(":2:"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d / "o" / "summary.json"));
  // Projectile inside the object.
  const fs::path inside = small_scene(d / "inside");
  std::string text = read(inside);
  text.replace(text.find("position = [0, -0.17, 0.25]"), 27, "position = [0, 0.0, 0.25]");
  std::ofstream(inside) << text;
  r = run_mca("run " + inside.string() + " --out " + (d / "o2").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("projectile[0]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("move the projectile"), std::string::npos) << r.output;
  // Unwritable output folder (a path under a regular file fails even as root).
  std::ofstream(d / "file") << "x";
  r = run_mca("run " + small_scene(d / "w").string() + " --out " + (d / "file" / "out").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find((d / "file" / "out").string()), std::string::npos) << r.output;
  // Too many automata for the memory limit, with the estimate.
  const fs::path huge = small_scene(d / "huge");
  text = read(huge);
  text.replace(text.find("spacing = 0.05"), 14, "spacing = 0.0005\nmax_memory_gb = 1");
  std::ofstream(huge) << text;
  r = run_mca("run " + huge.string() + " --out " + (d / "o3").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("GB"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("spacing"), std::string::npos) << r.output;
  // Command-line values.
  r = run_mca("run --duration -1");
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("--duration"), std::string::npos) << r.output;
  // An infinite duration is the option's, not the scene file's (it was blamed on the scene).
  r = run_mca("run --duration inf --out " + (d / "o4").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("--duration inf must be a positive, finite number of seconds"), std::string::npos)
      << r.output;
  // Integer options past their type are named as typed, with the range and what to give (CLI11 said
  // "Could not convert", and took 99999999999999999999 steps for 9223372036854775807: the hostile review of
  // 2026-12-06).
  for (const auto& [args, part] : std::vector<std::pair<std::string, std::string>>{
           {"run --threads 2147483648", "--threads: 2147483648 is not a whole number from 0 to 2147483647; give 0 (all "
                                        "cores) or a count of worker threads"},
           {"run --checkpoint-every 3000000000", "3000000000 is not a whole number from 0 to 2147483647; give 0 "
                                                 "(none) or a number of frames"},
           {"run --steps 99999999999999999999", "99999999999999999999 is not a whole number from 1 to "
                                                "9223372036854775807; give a number of steps"},
           {"run --steps 1.5", "1.5 is not a whole number from 1"},
           {"resume x --threads -1", "-1 is not a whole number from 0 to 2147483647"},
           {"bench --repeats 0", "0 is not a whole number from 1 to 2147483647; give a number of timed runs"},
           {"bench --frames 3 wall_3k", "--frames requires --render"},  // (each was ignored by the other kind)
           {"bench --render --repeats 3 wall_3k", "--repeats excludes --render"},
           {"view --frames 1e3", "1e3 is not a whole number from 1 to 2147483647; give a number of frames"}}) {
    r = run_mca(args);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_NE(r.output.find(part), std::string::npos) << args << ": " << r.output;
    EXPECT_EQ(r.output.find("Could not convert"), std::string::npos) << args << ": " << r.output;
  }
  // As CLI11 took them before the check: a leading '+' or space.
  for (const char* steps : {"+1", "' 1'"}) {
    r = run_mca(std::string("run --steps ") + steps + " -q --no-vtk --out " + (d / "plus").string());
    EXPECT_EQ(r.code, 0) << steps << ": " << r.output;
  }
  r = run_mca("bench no_such_bench");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("wall_357k"), std::string::npos) << r.output;
  // The rate is the median run's: steps over median_wall_seconds, also of an even count of runs (it was the
  // mean of the two middle rates, not the rate of the two middle times).
  r = run_mca("bench wall_3k --steps 2 --repeats 2 --json --threads 1");
  ASSERT_EQ(r.code, 0) << r.output;
  {
    const auto j = nlohmann::json::parse(r.output)[0];
    EXPECT_DOUBLE_EQ(j["automaton_steps_per_second"].get<double>(),
                     j["automata"].get<double>() * 2 / j["median_wall_seconds"].get<double>());
    EXPECT_EQ(j["steps_run_on"], "1 thread");
    EXPECT_TRUE(j["cuda_lattice"].is_null());
  }
  r = run_mca("resume " + (d / "empty").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("checkpoint"), std::string::npos) << r.output;
}

TEST(Cli, UnstableRunStopsWithTheCauseAndKeepsTheLastGoodFrame) {
  // A valid scene cannot blow up any more (the time step is bounded by every stiffness, and a step given
  // by hand above the bound is refused), so the test plants a blow-up: a checkpoint whose first automaton
  // that still holds a link moves at 1e30 m/s (its link's force overflows float), which the resumed run
  // must catch, name, and stop at with the frames before it kept on disk. (An automaton that has broken
  // free flies on at 1e30 m/s with finite values: the energy check stops that run, without a name.)
  const fs::path d = fresh_dir("unstable");
  const fs::path scene = small_scene(d);
  const fs::path out = d / "out";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + out.string() + " -q --checkpoint-every 1").code, 0);
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(out / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  ASSERT_GE(cks.size(), 2u);
  fs::remove(cks.back());
  fs::remove(out / "summary.json");
  mcaio::Checkpoint cp = mcaio::read_checkpoint(cks.front());
  const mca::Engine built(mcaio::load_scene_file(scene));
  const auto& E = built.model().explicit_links;  // (the random lattice: every link is explicit)
  const std::size_t slot0 = 3 * built.model().size();
  std::size_t k = 0;
  while (k < E.size() && !cp.state.intact[slot0 + k]) ++k;
  ASSERT_LT(k, E.size());
  const std::uint32_t a = E.i[k];
  cp.state.v[a] = {1e30f, 0, 0};
  mcaio::write_checkpoint(cks.front(), cp);
  const Result r = run_mca("resume " + out.string() + " -q");
  EXPECT_EQ(r.code, 3) << r.output;
  EXPECT_NE(r.output.find("unstable"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("solver.safety"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(fmt::format("non-finite position, velocity or orientation at automaton {}", a)), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(out / "frames" / fmt::format("automata_{:06d}.vtu", cp.frame - 1)));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

}  // namespace

namespace {

// Runs `mca args` with `dir` as the current folder.
Result mca_in(const fs::path& dir, const std::string& args) {
  return shell("cd '" + dir.string() + "' && " + std::string(MCA_BINARY) + " " + args);
}

// The small scene under another name (written as a TOML literal string, so any text but ' fits).
fs::path named_scene(const fs::path& dir, const std::string& name) {
  const fs::path p = small_scene(dir);
  std::string text = read(p);
  text.replace(text.find("name = \"small\""), 14, "name = '" + name + "'");
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST(Cli, SceneNameCannotPickTheOutputFolder) {
  const fs::path d = fresh_dir("scene_name");
  const fs::path work = d / "work";
  fs::create_directories(work);
  // Files of an earlier run in the current folder, which a name of ".." would replace or delete.
  std::ofstream(work / "stats.csv") << "keep me\n";
  std::ofstream(work / "summary.json") << "{}\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"../escaped", "___escaped"}, {(d / "abs").string(), ""}, {"..", "__"}, {".", "_"},
      {"a/b", "a_b"}, {"", "scene"}, {"my scene \xC3\xA9", "my_scene__"}};
  for (const auto& [name, folder] : cases) {
    SCOPED_TRACE(name);
    const Result r = mca_in(work, "run " + named_scene(d / "scenes", name).string() + " -q --steps 1 --no-vtk");
    ASSERT_EQ(r.code, 0) << r.output;
    if (!folder.empty()) {
      EXPECT_TRUE(fs::exists(work / "out" / folder / "summary.json")) << folder;
    }
    // Everything the run wrote is in a direct child of out/.
    for (const auto& e : fs::directory_iterator(work / "out")) EXPECT_TRUE(e.is_directory()) << e.path();
  }
  EXPECT_FALSE(fs::exists(d / "escaped"));
  EXPECT_FALSE(fs::exists(work / "escaped"));
  EXPECT_FALSE(fs::exists(d / "abs"));
  EXPECT_EQ(read(work / "stats.csv"), "keep me\n");
  EXPECT_EQ(read(work / "summary.json"), "{}\n");
  EXPECT_FALSE(fs::exists(work / "scene.toml"));
  // The name itself is kept for display.
  const auto j = nlohmann::json::parse(read(work / "out" / "___escaped" / "summary.json"));
  EXPECT_EQ(j["scene"], "../escaped");
}

namespace {

// `mca args` stopped after a minute: a damaged input must fail fast, not run away (exit code 124).
Result mca_timed(const std::string& args) { return shell("timeout 60 " + std::string(MCA_BINARY) + " " + args); }

// A run of the small scene with a checkpoint every 2 frames; returns the newest checkpoint (frame 4).
fs::path checkpointed_run(const fs::path& d) {
  const Result r = run_mca("run " + small_scene(d).string() + " --out " + (d / "out").string() +
                       " -q --no-vtk --checkpoint-every 2");
  EXPECT_EQ(r.code, 0) << r.output;
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(d / "out" / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  return cks.empty() ? fs::path() : cks.front();  // frame 2: the run still has frames to go
}

}  // namespace

// A file where a run writes a folder (frames, checkpoints, ...) is refused before anything is written, with
// the exit code of bad input: found at the first write into it, it gave a raw filesystem error (exit 1),
// partway through a run and with no checkpoint (the hostile review of 2026-12-05). A resume is refused the
// same way, and leaves the folder as it was.
TEST(Cli, AFileWhereARunWritesAFolderIsRefusedBeforeItStarts) {
  const fs::path d = fresh_dir("file_as_folder");
  // The small scene with fragment meshes (output.fragments).
  const fs::path scene = mca::test::small_scene_with_output(d, "fragments = true\n");
  for (const char* sub : {"frames", "checkpoints", "fragments", "render"}) {
    SCOPED_TRACE(sub);
    const fs::path out = d / sub;
    fs::create_directories(out);
    std::ofstream(out / sub) << "x\n";
    const Result r = run_mca("run " + scene.string() + " --out " + out.string() + " -q --render --render-size 64x48");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(fmt::format("'{}' is there and is not a folder: the run writes", (out / sub).string())),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("into a folder of that name; move or remove it"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("filesystem error"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out / "scene.toml"));
    EXPECT_FALSE(fs::exists(out / "stats.csv"));
    EXPECT_EQ(read(out / sub), "x\n");
  }
  // Files named as folders a run does not write are left alone (render without --render, surface without a
  // mesh, frames with --no-vtk: refused before, with a message saying the run wrote there).
  {
    const fs::path out = d / "unused";
    fs::create_directories(out);
    for (const char* sub : {"render", "surface", "frames"}) std::ofstream(out / sub) << "x\n";
    const Result r = run_mca("run " + small_scene(d, "", "plain").string() + " --out " + out.string() + " -q --no-vtk");
    EXPECT_EQ(r.code, 0) << r.output;
    for (const char* sub : {"render", "surface", "frames"}) EXPECT_EQ(read(out / sub), "x\n") << sub;
  }
  // A subfolder that is a link to a folder elsewhere is refused, whether this run writes there or not, and
  // the link and what it points at are left as they were: a run clears an earlier run's files out of every
  // subfolder, and through a link it removed and wrote files outside its output folder (a folder of another
  // run's frames, checkpoints or pictures: the hostile review of 2026-12-06). A resume is refused alike.
  for (const char* sub : {"frames", "checkpoints", "render", "surface", "fragments"}) {
    SCOPED_TRACE(sub);
    const fs::path out = d / (std::string("linked_") + sub), elsewhere = d / (std::string("elsewhere_") + sub);
    // A finished run's folder (a new run replaces its files), its subfolder a link.
    ASSERT_EQ(run_mca("run " + small_scene(d, "", "plain").string() + " --out " + out.string() + " -q").code, 0);
    fs::remove_all(out / sub);
    fs::create_directories(elsewhere);
    for (const char* f : {"automata_000001.vtu", "frame_000003.mcack", "frame_000002.png", "video.mp4",
                          "fragment_001.ply", "surface_000001.ply"})
      std::ofstream(elsewhere / f) << "theirs\n";
    fs::create_directory_symlink(elsewhere, out / sub);
    for (const char* extra : {"", " --checkpoint-every 1"}) {
      const Result r =
          run_mca("run " + small_scene(d, "", "plain").string() + " --out " + out.string() + " -q --no-vtk" + extra);
      EXPECT_EQ(r.code, 2) << r.output;
      EXPECT_NE(r.output.find(fmt::format("'{}' is a symbolic link (to '{}'): a run writes", (out / sub).string(),
                                          elsewhere.string())),
                std::string::npos)
          << r.output;
      EXPECT_NE(r.output.find("writes and removes nothing outside its output folder; replace the link with a folder"),
                std::string::npos)
          << r.output;
    }
    EXPECT_TRUE(fs::is_symlink(out / sub));
    std::size_t theirs = 0;
    for (const auto& e : fs::directory_iterator(elsewhere)) theirs += read(e.path()) == "theirs\n";
    EXPECT_EQ(theirs, 6u);
  }
  {
    const fs::path out = d / "linked_resume", elsewhere = d / "elsewhere_resume";
    ASSERT_EQ(
        run_mca("run " + small_scene(d, "", "plain").string() + " --out " + out.string() + " -q --checkpoint-every 2")
            .code,
        0);
    fs::rename(out / "frames", elsewhere);
    fs::create_directory_symlink(elsewhere, out / "frames");
    const std::size_t before = static_cast<std::size_t>(std::distance(fs::directory_iterator(elsewhere), {}));
    const Result r = run_mca("resume " + out.string() + " -q");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("is a symbolic link"), std::string::npos) << r.output;
    EXPECT_EQ(static_cast<std::size_t>(std::distance(fs::directory_iterator(elsewhere), {})), before);
  }
  // A resume whose frames folder became a file.
  const fs::path out = d / "resumed";
  ASSERT_EQ(run_mca("run " + small_scene(d, "", "plain").string() + " --out " + out.string() + " -q --checkpoint-every 2")
                .code,
            0);
  fs::remove(out / "summary.json");
  fs::remove_all(out / "frames");
  std::ofstream(out / "frames") << "x\n";
  const std::string stats = read(out / "stats.csv");
  const Result r = run_mca("resume " + out.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("frames' is there and is not a folder: the run writes the VTK frames"), std::string::npos)
      << r.output;
  EXPECT_EQ(read(out / "stats.csv"), stats);
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

// A write that fails mid-run (here a full disk at frame 3's file) stops the run with exit 2, naming the
// newest checkpoint and the command that continues it; once the cause is gone the resume ends with the
// uninterrupted run's bits.
TEST(Cli, AWriteThatFailsMidRunNamesTheCheckpointThatContinuesIt) {
  const fs::path d = fresh_dir("write_fails");
  const fs::path scene = small_scene(d);
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + (d / "whole").string() + " -q").code, 0);
  const fs::path out = d / "out";
  const Result r =
      run_mca_full_at("frames/automata_000003.vtu", "run " + scene.string() + " --out " + out.string() + " -q --checkpoint-every 1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("automata_000003.vtu"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(fmt::format("The run stopped writing frame 3; once the disk has room (or the cause above is "
                                      "fixed), continue it from the newest checkpoint (frame_000002.mcack) with:\n"
                                      "  mca resume {}",
                                      out.string())),
            std::string::npos)
      << r.output;
  // A plot of the run so far is removed by the resume (it would show the state before), and the folder it
  // leaves empty with it.
  fs::create_directories(out / "render");
  std::ofstream(out / "render" / "energies.png") << "a plot";
  const Result resumed = run_mca("resume " + out.string() + " -q");
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_FALSE(fs::exists(out / "render"));
  EXPECT_EQ(nlohmann::json::parse(read(out / "summary.json"))["state_hash"],
            nlohmann::json::parse(read(d / "whole" / "summary.json"))["state_hash"]);
  // Frame 0, before any step: nothing to resume; the run is started again.
  const fs::path first = d / "first";
  const Result r0 = run_mca_full_at("frames/automata_000000.vtu", "run " + scene.string() + " --out " + first.string() + " -q");
  EXPECT_EQ(r0.code, 2) << r0.output;
  EXPECT_NE(r0.output.find("automata_000000.vtu"), std::string::npos) << r0.output;
  EXPECT_NE(r0.output.find("The run stopped writing frame 0, before its first step; once the disk has room (or the "
                           "cause above is fixed), start it again"),
            std::string::npos)
      << r0.output;
}

// A file that reaches the process's size limit (ulimit -f) killed the run with SIGXFSZ (exit 153, no word,
// a temporary file left); it is a write error that names the file, as a full disk is.
TEST(Cli, AFileSizeLimitIsAWriteErrorThatNamesTheFile) {
  const fs::path d = fresh_dir("file_size_limit");
  const fs::path scene = small_scene(d), out = d / "out";
  const Result r = shell("ulimit -f 60; " + std::string(MCA_BINARY) + " run " + scene.string() + " --out " +
                         out.string() + " -q --checkpoint-every 1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("could not write '" + out.string() + "/"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("': writing failed (File too large); the file reached a size limit (the process's, ulimit "
                          "-f, or the file system's)"),
            std::string::npos)
      << r.output;
  for (const auto& e : fs::recursive_directory_iterator(out)) EXPECT_NE(e.path().extension(), ".tmp") << e.path();
}

// A fragment mesh that cannot be written (a disk that fills at the run's end: the disk check counted single
// cells' meshes at a tenth of their size) lost the run: no summary, no fragments.csv, no checkpoint of its
// last state unless --checkpoint-every. The meshes written so far make room for a checkpoint of the last
// frame, and the resume writes the end from it, with the uninterrupted run's bits.
TEST(Cli, AFragmentMeshThatCannotBeWrittenLeavesACheckpointThatWritesTheEnd) {
  const fs::path d = fresh_dir("mesh_fails");
  const fs::path scene = mca::test::small_scene_with_output(d, "fragments = true\nfragment_min_automata = 0\n");
  const fs::path whole = d / "whole", out = d / "out";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + whole.string() + " -q").code, 0);
  ASSERT_TRUE(fs::exists(whole / "fragments" / "fragment_001.ply"));
  const Result r = run_mca_full_at("fragments/fragment_001.ply", "run " + scene.string() + " --out " + out.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("fragment_001.ply"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("The run stopped writing its fragment meshes, after its last step; those it had written are "
                          "removed, and a checkpoint of its last frame is saved: once the disk has room (or the cause "
                          "above is fixed), write them (and summary.json, fragments.csv) with:\n  mca resume " +
                          out.string()),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out / "fragments" / "fragment_000.ply"));
  EXPECT_EQ(nlohmann::json::parse(read(out / "summary.json"))["status"], "interrupted");
  const Result resumed = run_mca("resume " + out.string() + " -q");
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  const auto summary = nlohmann::json::parse(read(out / "summary.json"));
  EXPECT_EQ(summary["status"], "finished");
  EXPECT_EQ(summary["state_hash"], nlohmann::json::parse(read(whole / "summary.json"))["state_hash"]);
  EXPECT_EQ(read(out / "fragments" / "fragment_001.ply"), read(whole / "fragments" / "fragment_001.ply"));
  EXPECT_EQ(read(out / "fragments.csv"), read(whole / "fragments.csv"));
}

// The disk check's bound on the fragment meshes holds a run shattered to single cells, on both lattices
// (it counted 1.6 KB a cell where one takes 15 to 22 KB), and mca info names it.
TEST(Cli, TheFragmentMeshesFitTheirEstimate) {
  const fs::path d = fresh_dir("mesh_estimate");
  for (const char* lattice : {"random", "cubic"}) {
    SCOPED_TRACE(lattice);
    const fs::path scene =
        mca::test::small_scene_with_output(d, "vtk = false\nfragments = true\nfragment_min_automata = 0\n", lattice);
    {
      std::string text = read(scene);
      text.replace(text.find("[solver]\n"), 9, std::string("[solver]\nlattice = \"") + lattice + "\"\n");
      text.replace(text.find("velocity = [0, 60, 0]"), 21, "velocity = [0, 200, 0]");
      std::ofstream(scene) << text;
    }
    const Result info = run_mca("info " + scene.string() + " --json");
    ASSERT_EQ(info.code, 0) << info.output;
    const double bound = nlohmann::json::parse(info.output)["output_bytes_fragment_meshes"].get<double>();
    const fs::path out = d / (std::string("out_") + lattice);
    ASSERT_EQ(run_mca("run " + scene.string() + " --out " + out.string() + " -q").code, 0);
    double written = 0, singles = 0;
    for (const auto& e : fs::directory_iterator(out / "fragments")) written += static_cast<double>(e.file_size());
    const auto summary = nlohmann::json::parse(read(out / "summary.json"));
    for (const auto& bin : summary["fragment_sizes"])
      if (bin["automata_max"] == 1) singles = bin["fragments"].get<double>();
    EXPECT_GT(singles, 0.5 * summary["automata"].get<double>()) << "not shattered: " << singles;
    EXPECT_LT(written, bound);
    EXPECT_GT(written, 0.4 * bound) << "the bound is far above a shattered run's meshes";
    const Result text = run_mca("info " + scene.string());
    EXPECT_NE(text.output.find("the fragment meshes at most " + mca::text::human_bytes(bound) + ", were every piece of 1 automaton"),
              std::string::npos)
        << text.output;
  }
}

// A folder (or a FIFO) at the name of a file the run will write stopped the run only when it came to it: at
// frame 2,000's checkpoint, hours in. A run and a resume refuse it before they start, and leave the folder
// as it was.
TEST(Cli, AFolderAtTheNameOfAFileTheRunWillWriteIsRefusedBeforeItStarts) {
  const fs::path d = fresh_dir("folder_at_name");
  const fs::path scene = small_scene(d);
  for (const char* name : {"checkpoints/frame_002000.mcack", "frames/automata_000005.vtu", "summary.json"}) {
    SCOPED_TRACE(name);
    const fs::path out = d / "out";
    fs::remove_all(out);
    ASSERT_EQ(run_mca("run " + scene.string() + " --out " + out.string() + " -q --no-vtk").code, 0);
    fs::remove(out / name);
    fs::create_directories(out / name / "mine");
    const Result r = run_mca("run " + scene.string() + " --out " + out.string() + " -q --checkpoint-every 1");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(fmt::format("'{}' is a folder at the name of a file a run writes or replaces there: the "
                                        "run would stop when it came to it",
                                        (out / name).string())),
              std::string::npos)
        << r.output;
    EXPECT_TRUE(fs::is_directory(out / name / "mine"));
  }
  // A resume alike (a FIFO at a frame's name: opening it would block; a broken link at stats.csv: its rows
  // were lost without a word).
  const fs::path out = d / "resumed";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + out.string() + " -q --checkpoint-every 2").code, 0);
  fs::remove(out / "summary.json");
  ASSERT_EQ(::mkfifo((out / "frames" / "automata_000099.vtu").c_str(), 0600), 0);
  const Result r = run_mca("resume " + out.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("automata_000099.vtu' is not a regular file (a FIFO, a device, a broken link)"),
            std::string::npos)
      << r.output;
  fs::remove(out / "frames" / "automata_000099.vtu");
  fs::rename(out / "stats.csv", d / "stats.csv");
  fs::create_symlink(d / "nowhere.csv", out / "stats.csv");
  const Result link = run_mca("resume " + out.string() + " -q");
  EXPECT_EQ(link.code, 2) << link.output;
  EXPECT_NE(link.output.find("stats.csv' is not a regular file (a FIFO, a device, a broken link)"), std::string::npos)
      << link.output;
  fs::remove(out / "stats.csv");
  fs::rename(d / "stats.csv", out / "stats.csv");
  // A file of a checkpoint's name that is none, newest: named, with the way to the one before.
  std::ofstream(out / "checkpoints" / "frame_000099.mcack") << "junk";
  const Result junk = run_mca("resume " + out.string() + " -q");
  EXPECT_EQ(junk.code, 2) << junk.output;
  EXPECT_NE(junk.output.find("frame_000099.mcack' is not an mca checkpoint (bad header): move it out of its folder, or "
                             "remove it, to use the checkpoint before it"),
            std::string::npos)
      << junk.output;
  fs::remove(out / "checkpoints" / "frame_000099.mcack");
  const Result resumed = run_mca("resume " + out.string() + " -q");
  EXPECT_EQ(resumed.code, 0) << resumed.output;
}

// The run's peak memory, not only its arrays, is held to solver.max_memory_gb before anything is written:
// a shell's fragment meshes that needed 21 GB under a limit of 4 ran out of memory at the run's end.
TEST(Cli, ARunWhosePeakExceedsTheMemoryLimitIsRefusedBeforeItStarts) {
  const fs::path d = fresh_dir("memory_peak");
  const fs::path small = small_scene(d);
  std::string text = read(small);
  text.replace(text.find("[solver]\n"), 9, "[solver]\nmax_memory_gb = 0.1\n");
  const fs::path scene = d / "limited.toml";
  std::ofstream(scene) << text;
  // The arrays fit (about 45 MB); the renderer's 120 MB at 1280x720 do not.
  const Result r = run_mca("run " + scene.string() + " --render --out " + (d / "out").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("at its peak (rendering"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("over solver.max_memory_gb = 0.1; render smaller pictures (--render-size) or leave out "
                          "--render"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(d / "out"));
  EXPECT_EQ(run_mca("run " + scene.string() + " -q --no-vtk --out " + (d / "out").string()).code, 0);
}

// The embedded scene of a checkpoint edited in place (same length): the rebuilt model is not the one
// the state was saved from. Resuming must refuse, not run on (or crash on) a mismatched state.
TEST(Cli, TamperedCheckpointIsRefusedOnResume) {
  const std::vector<std::pair<std::string, std::string>> edits = {
      {"size = [0.6, 0.15, 0.5]", "size = [0.6, 0.15, 0.3]"},       // fewer automata than the state holds
      {"size = [0.6, 0.15, 0.5]", "size = [0.6, 0.15, 0.7]"},       // more
      {"position = [0.0, 0.0, 0.25]", "position = [0.0, 0.0, 0.35]"},  // same counts, another model
      {"radius = 0.08", "radius = 0.07"}};                           // same automata, another ball
  int k = 0;
  for (const auto& [from, to] : edits) {
    SCOPED_TRACE(to);
    const fs::path d = fresh_dir("tamper" + std::to_string(k++));
    const fs::path ck = checkpointed_run(d);
    ASSERT_FALSE(ck.empty());
    std::string bytes = read(ck);
    const auto at = bytes.find(from);
    ASSERT_NE(at, std::string::npos) << "the embedded scene has no '" << from << "'";
    bytes.replace(at, from.size(), to);
    std::ofstream(ck, std::ios::binary | std::ios::trunc) << bytes;
    for (const auto& e : fs::directory_iterator(d / "out" / "checkpoints"))
      if (e.path() != ck) fs::remove(e.path());
    const Result r = mca_timed("resume " + (d / "out").string() + " -q");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(ck.string()), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("start the run again"), std::string::npos) << r.output;
  }
}

// Frame and step counters of a checkpoint that do not fit each other are refused too (a huge frame
// number would otherwise make resume list 2^40 frames).
TEST(Cli, CheckpointWithAnAbsurdFrameIsRefused) {
  const fs::path d = fresh_dir("absurd_frame");
  const fs::path ck = checkpointed_run(d);
  ASSERT_FALSE(ck.empty());
  std::string bytes = read(ck);
  // Layout: magic (8), scene length (8), scene text, model fingerprint (8), frame (8).
  std::uint64_t len = 0;
  std::memcpy(&len, bytes.data() + 8, 8);
  const std::int64_t frame = std::int64_t{1} << 40;
  std::memcpy(bytes.data() + 16 + len + 8, &frame, 8);
  std::ofstream(ck, std::ios::binary | std::ios::trunc) << bytes;
  for (const auto& e : fs::directory_iterator(d / "out" / "checkpoints"))
    if (e.path() != ck) fs::remove(e.path());
  const Result r = mca_timed("resume " + (d / "out").string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("frame"), std::string::npos) << r.output;
}

// A new run in a folder replaces what an earlier run wrote there; collections (.pvd) of frames that
// this run does not write must go too, or ParaView opens frames that were deleted.
TEST(Cli, RerunRemovesStaleFrameCollections) {
  const fs::path d = fresh_dir("rerun_pvd");
  const fs::path out = d / "out";
  ASSERT_EQ(run_mca("run " + small_scene(d).string() + " --out " + out.string() + " -q --steps 2").code, 0);
  ASSERT_TRUE(fs::exists(out / "projectiles.pvd"));
  ASSERT_TRUE(fs::exists(out / "automata.pvd"));
  // The same wall without its ball: no projectile frames, so no projectiles.pvd.
  const fs::path no_ball = small_scene(d / "no_ball");
  std::string text = read(no_ball);
  text.erase(text.find("[[projectile]]"));
  std::ofstream(no_ball) << text;
  Result r = run_mca("run " + no_ball.string() + " --out " + out.string() + " -q --steps 2");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_FALSE(fs::exists(out / "projectiles.pvd"));
  EXPECT_TRUE(fs::exists(out / "automata.pvd"));
  // No VTK at all: no automata.pvd either.
  r = run_mca("run " + small_scene(d).string() + " --out " + out.string() + " -q --steps 2 --no-vtk");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_FALSE(fs::exists(out / "automata.pvd"));
  EXPECT_FALSE(fs::exists(out / "projectiles.pvd"));
  EXPECT_FALSE(fs::exists(out / "frames" / "automata_000000.vtu"));
}

// Checkpoint names carry the frame zero-padded to six digits; past frame 999999 they grow a digit, and
// text order would put frame_1000000 before frame_999999. Resume must take the newest by number.
TEST(Cli, ResumeTakesTheNewestCheckpointByFrameNumber) {
  const fs::path d = fresh_dir("ck_order");
  checkpointed_run(d);
  const fs::path ckdir = d / "out" / "checkpoints";
  ASSERT_TRUE(fs::exists(ckdir / "frame_000004.mcack"));
  fs::rename(ckdir / "frame_000002.mcack", ckdir / "frame_999999.mcack");
  fs::rename(ckdir / "frame_000004.mcack", ckdir / "frame_1000000.mcack");
  const Result r = run_mca("resume " + (d / "out").string());
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("frame_1000000.mcack"), std::string::npos) << r.output;
}

// Step counts near 2^63 overflowed the frame arithmetic (negative frame counts, a run that never ends);
// an empty --out was silently ignored (the run went to out/<name>).
TEST(Cli, AbsurdStepCountsAndEmptyFoldersAreRefused) {
  const fs::path d = fresh_dir("absurd_cli");
  const fs::path scene = small_scene(d);
  const std::string out = " --out " + (d / "o").string();
  for (const std::string steps : {"9223372036854775807", "9223372036854775000", "1000000000000001"}) {
    const Result r = mca_timed("run " + scene.string() + out + " --steps " + steps);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("--steps " + steps), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("frames, "), std::string::npos) << "a plan was made: " << r.output;
  }
  Result r = mca_timed("run " + scene.string() + out + " --duration 1e300");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("output.duration"), std::string::npos) << r.output;
  r = mca_in(d, "run " + scene.string() + " --out '' -q --steps 1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d / "out")) << "an empty --out fell back to out/<name>";
  r = mca_in(d, "resume ''");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("folder"), std::string::npos) << r.output;
}

// "Largest first" means by mass: a small steel block outweighs a larger concrete wall.
TEST(Cli, FragmentsAreListedHeaviestFirst) {
  const fs::path d = fresh_dir("heaviest");
  // 12 x 3 x 10 = 360 concrete automata (2400 kg/m^3) and 7 x 3 x 7 = 147 steel ones (7850 kg/m^3).
  const fs::path scene = small_scene(d, R"(
[[object]]
name = "steel_block"
size = [0.35, 0.15, 0.35]
position = [1.5, 0, 0.175]
material = "steel"
)");
  const Result r = run_mca("run " + scene.string() + " --out " + (d / "out").string() + " -q --steps 1 --no-vtk");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto j = nlohmann::json::parse(read(d / "out" / "summary.json"));
  ASSERT_GE(j["fragments"].size(), 2u);
  EXPECT_EQ(j["fragments"][0]["automata"], 147) << j["fragments"].dump();
  EXPECT_EQ(j["fragments"][1]["automata"], 360) << j["fragments"].dump();
  for (std::size_t k = 1; k < j["fragments"].size(); ++k)
    EXPECT_GE(j["fragments"][k - 1]["mass"].get<double>(), j["fragments"][k]["mass"].get<double>());
}

namespace {

// The command line's own mistakes: --out on the scene's folder would overwrite the scene file; a seed
// beyond 64 bits or written as a float; an unknown option (exit 2 like every user error).
TEST(Cli, CommandLineMistakesAreRefused) {
  const fs::path d = fresh_dir("cmdline");
  const fs::path scene = d / "scene.toml";
  fs::create_directories(d);
  fs::copy_file(small_scene(d / "src"), scene);
  const std::string before = read(scene);
  Result r = run_mca("run " + scene.string() + " --out " + d.string() + " -q --steps 1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("would overwrite the scene file"), std::string::npos) << r.output;
  EXPECT_EQ(read(scene), before);
  for (const char* seed : {"1e23", "18446744073709551616", "-1"}) {
    r = run_mca("run " + scene.string() + " --out " + (d / "o").string() + " -q --steps 1 --seed " + seed);
    EXPECT_EQ(r.code, 2) << seed << ": " << r.output;
  }
  r = run_mca("run --no-such-option");
  EXPECT_EQ(r.code, 2) << r.output;
}

// `mca info`'s memory estimate is what a run of the scene holds at its peak (it said half: 47 MB for a
// measured 95 MB at 100,000 automata), so the max_memory_gb check and the machine check mean something.
// A bad MCA_SIMD (the instruction set of the step) is refused before the output folder is made.
TEST(Cli, UnknownInstructionSetIsRefusedBeforeAnythingIsWritten) {
  const fs::path d = fresh_dir("simd");
  const Result r = shell("MCA_SIMD=avx9 " + std::string(MCA_BINARY) + " run --steps 5 -q --out " + d.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("MCA_SIMD"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d)) << "an output folder was made";
  const Result info = shell("MCA_SIMD=sse2 " + std::string(MCA_BINARY) + " info --json");
  ASSERT_EQ(info.code, 0) << info.output;
  EXPECT_EQ(nlohmann::json::parse(info.output)["backend"], "cpu-sse2");
}

// MCA_BACKEND says what backend auto stands for (the tests set cpu: test_environment.cpp); a value that is no
// backend is refused, naming the variable, before anything is written.
TEST(Cli, McaBackendSaysWhatAutoStandsFor) {
  const Result emulated = shell("MCA_BACKEND=cuda-emulation " + std::string(MCA_BINARY) + " info --json");
  ASSERT_EQ(emulated.code, 0) << emulated.output;
  EXPECT_EQ(nlohmann::json::parse(emulated.output)["backend"], "cuda-emulation");
  const Result cpu = shell("MCA_BACKEND=cpu MCA_SIMD=sse2 " + std::string(MCA_BINARY) + " info --json");
  ASSERT_EQ(cpu.code, 0) << cpu.output;
  EXPECT_EQ(nlohmann::json::parse(cpu.output)["backend"], "cpu-sse2");
  // Any case, as MCA_SIMD (which took SSE2 where CPU was refused).
  const Result upper = shell("MCA_BACKEND=CPU MCA_SIMD=SSE2 " + std::string(MCA_BINARY) + " info --json");
  ASSERT_EQ(upper.code, 0) << upper.output;
  EXPECT_EQ(nlohmann::json::parse(upper.output)["backend"], "cpu-sse2");
  const fs::path d = fresh_dir("mca_backend");
  const Result bad = shell("MCA_BACKEND=gpu " + std::string(MCA_BINARY) + " run --steps 5 -q --out " + d.string());
  EXPECT_NE(bad.code, 0) << bad.output;
  EXPECT_NE(bad.output.find("MCA_BACKEND = 'gpu'"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("cuda-emulation"), std::string::npos) << bad.output;
  EXPECT_FALSE(fs::exists(d)) << "an output folder was made";
}

// `mca info --backend` as run's (it had none: `mca info --backend cuda-emulation SCENE` took the backend for
// the scene); over MCA_BACKEND and solver.backend. Its JSON "backend" is a name, as summary.json's.
TEST(Cli, InfoTakesTheBackendAsRunDoes) {
  const Result emulated = shell("MCA_BACKEND=cpu " + std::string(MCA_BINARY) + " info --backend cuda-emulation --json");
  ASSERT_EQ(emulated.code, 0) << emulated.output;
  EXPECT_EQ(nlohmann::json::parse(emulated.output)["backend"], "cuda-emulation");
  EXPECT_TRUE(nlohmann::json::parse(emulated.output)["gpu_memory_bytes"].is_number());
  const Result bad = run_mca("info --backend gpu");
  EXPECT_EQ(bad.code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--backend 'gpu'"), std::string::npos) << bad.output;
  std::string why;
  if (!mca::cuda_device(&why).empty()) return;  // (a GPU here: cuda runs)
  const Result cuda = run_mca("info --backend cuda --json");
  ASSERT_EQ(cuda.code, 0) << cuda.output;
  const auto j = nlohmann::json::parse(cuda.output);
  EXPECT_EQ(j["backend"], "cuda");  // (it read "cuda (not available here)")
  EXPECT_EQ(j["backend_runs_here"], false);
  EXPECT_EQ(j["cuda_unavailable"], why);
  const Result text = run_mca("info --backend cuda");
  EXPECT_NE(text.output.find("backend          cuda (--backend), which cannot run here: " + why), std::string::npos)
      << text.output;
}

// Writes `text` as a scene in a fresh folder `name`, then reads `mca info --json` of it and runs it: the
// info and the run's summary.json.
void info_and_run(const std::string& name, const std::string& text, nlohmann::json& info, nlohmann::json& summary) {
  const fs::path d = fresh_dir(name);
  fs::create_directories(d);
  const fs::path scene = d / "scene.toml";
  std::ofstream(scene) << text;
  const Result i = run_mca("info " + scene.string() + " --json");
  ASSERT_EQ(i.code, 0) << i.output;
  info = nlohmann::json::parse(i.output);
  const Result r = run_mca("run " + scene.string() + " --out " + (d / "out").string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  summary = nlohmann::json::parse(read(d / "out" / "summary.json"));
}

TEST(Cli, MemoryEstimateMatchesThePeak) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine triple the resident size";
#endif
  // On both lattices (the random one's run peaked 7 % above the estimate when it became the default).
  for (const std::string lattice : {"random", "cubic"}) {
    nlohmann::json info, summary;
    ASSERT_NO_FATAL_FAILURE(info_and_run("memory_" + lattice, R"(name = "m100k"
[solver]
spacing = 0.01
lattice = ")" + lattice + R"("
[output]
frame_rate = 1e6
duration = 2e-6
[[object]]
size = [0.5, 0.4, 0.5]
[[projectile]]
radius = 0.05
position = [0, -0.3, 0]
velocity = [0, 20, 0]
)",
                                         info, summary));
    const double estimate = info["memory_bytes"].get<double>();
    const double peak = summary["peak_memory_bytes"].get<double>();
    std::printf("100,000 automata, %s lattice: estimate %.1f MB, peak resident %.1f MB\n", lattice.c_str(), estimate / 1e6,
                peak / 1e6);
    EXPECT_GT(estimate, 0.95 * peak) << lattice;
    EXPECT_LT(estimate, 1.5 * peak) << lattice;
  }
}

// A small volume-filled mesh holds what a large one's triangles are counted for: a turned cube of 12
// triangles (840 automata) peaked 8 MB above a box of 1,728 on one thread, 15 MB on two, where mca info
// counted nothing for its mesh (a hostile review, 2026-12-08: OpenVDB's signed distance on every thread).
TEST(Cli, MemoryEstimateOfASmallMeshFillHoldsItsPeak) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine triple the resident size";
#endif
  const fs::path d = fresh_dir("memory_cube_mesh");
  fs::create_directories(d);
  mca::test::write_mesh_file(d / "cube.off", mca::test::cube_mesh(1.0));
  nlohmann::json info, summary;
  ASSERT_NO_FATAL_FAILURE(info_and_run("memory_cube_fill", fmt::format(R"(name = "cube"
[solver]
spacing = 0.05
gravity = [0, 0, 0]
[output]
frame_rate = 1e5
duration = 1e-4
vtk = false
[[object]]
shape = "mesh"
mesh = "{}"
fit_size = 0.6
rotation = [30, 45, 10]
)",
                                                                        (d / "cube.off").string()),
                                       info, summary));
  const double estimate = info["memory_bytes"].get<double>(), peak = summary["peak_memory_bytes"].get<double>();
  std::printf("a volume-filled cube of 12 triangles, %d automata: estimate %.1f MB, peak resident %.1f MB\n",
              info["automata"].get<int>(), estimate / 1e6, peak / 1e6);
  EXPECT_GT(estimate, peak);
  EXPECT_LT(estimate, 1.5 * peak);
}

// A body shattered to rubble holds more contact pairs than the run's estimate counts (one an automaton):
// `mca info` gives the peak for that case too (memory_bytes_shattered). A glass cube of 27,000 automata
// thrown on the ground at 80 m/s loses nine in ten of its links within 1.5 ms.
TEST(Cli, MemoryEstimateOfRubbleMatchesThePeak) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine triple the resident size";
#endif
  nlohmann::json j, summary;
  ASSERT_NO_FATAL_FAILURE(info_and_run("memory_rubble", R"(name = "shatter"
[solver]
spacing = 0.01
lattice = "cubic"
[output]
duration = 0.0015
frame_rate = 1000
vtk = false
[ground]
enabled = true
[[object]]
size = [0.3, 0.3, 0.3]
position = [0, 0, 0.16]
velocity = [0, 0, -80]
material = "glass"
)",
                                       j, summary));
  const double estimate = j["memory_bytes"].get<double>(), shattered = j["memory_bytes_shattered"].get<double>();
  const double peak = summary["peak_memory_bytes"].get<double>();
  const double broken = summary["broken_links"]["total"].get<double>(), links = j["links"].get<double>();
  std::printf("27,000 automata shattered (%.0f of %.0f links broken): estimate %.1f MB, shattered %.1f MB, peak %.1f MB\n",
              broken, links, estimate / 1e6, shattered / 1e6, peak / 1e6);
  ASSERT_GT(broken, 0.8 * links) << "the cube did not shatter: the test no longer measures rubble";
  EXPECT_LT(estimate, 0.95 * peak) << "the run's estimate alone now covers rubble: the test no longer needs the term";
  EXPECT_GT(shattered, 0.95 * peak);
  EXPECT_LT(shattered, 1.5 * peak);
}

// A checkpoint of the same scene run for another step count (copied in from another folder) would end the
// folder at that run's end: it is refused, both ways (a --steps run's folder, a duration's).
TEST(Cli, ACheckpointOfTheSameSceneRunForAnotherStepCountIsRefused) {
  const fs::path d = fresh_dir("other_steps");
  const fs::path scene = small_scene(d);
  const fs::path whole = d / "whole", cut = d / "cut";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + whole.string() + " -q --checkpoint-every 1").code, 0);
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + cut.string() + " -q --checkpoint-every 1 --steps 40").code, 0);
  const auto newest = [](const fs::path& run) { return mca::io::list_checkpoints(run / "checkpoints").back(); };
  for (const auto& [from, into] : {std::pair{whole, cut}, std::pair{cut, whole}}) {
    const fs::path copy = d / ("into_" + into.filename().string());
    fs::copy(into, copy, fs::copy_options::recursive);
    fs::remove(copy / "summary.json");
    fs::copy_file(newest(from), copy / "checkpoints" / "frame_000099.mcack");
    const Result r = run_mca("resume " + copy.string() + " -q");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("frame_000099.mcack' is of a run of "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(into == cut ? " is of 40 (its scene.toml's --steps): it was copied in from another run"
                                        : " (its scene.toml's output.duration): it was copied in from another run"),
              std::string::npos)
        << r.output;
    const int steps = nlohmann::json::parse(read(from / "summary.json"))["steps"];
    EXPECT_NE(r.output.find(fmt::format("is of a run of {} steps", steps)), std::string::npos) << r.output;
  }
}

// The fragment meshes are made and written one piece at a time, and `mca info` counts the largest piece's:
// for a shell of 20,480 triangles (meshed on both sides) they are most of the run's peak, which
// summary.json measures after them. (Held all at once and counted by the box, a box in 2,745 pieces
// peaked at 151 MB where it now takes 90, and the armadillo at 880 MB for an estimate of 1.7 GB.)
TEST(Cli, MemoryEstimateOfFragmentMeshesMatchesThePeak) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine triple the resident size";
#endif
  const fs::path d = fresh_dir("memory_fragments_mesh");
  fs::create_directories(d);
  mca::test::write_mesh_file(d / "ball.off", mca::test::sphere_mesh(0.5, 5));
  nlohmann::json info, summary;
  ASSERT_NO_FATAL_FAILURE(info_and_run("memory_fragments", R"(name = "shell"
[output]
frame_rate = 1e6
duration = 2e-6
vtk = false
fragments = true
[[object]]
shape = "mesh"
mesh = ")" + (d / "ball.off").string() + R"("
fill = "surface"
material = "concrete"
)",
                                       info, summary));
  const double estimate = info["memory_bytes"].get<double>(), meshes = info["memory"]["fragment_meshes"].get<double>();
  const double peak = summary["peak_memory_bytes"].get<double>();
  std::printf("a shell of 20,480 triangles: estimate %.1f MB (fragment meshes %.1f MB), peak resident %.1f MB\n",
              estimate / 1e6, meshes / 1e6, peak / 1e6);
  EXPECT_GT(meshes, 0.5 * estimate) << "the fragment meshes are no longer the largest part: the test measures another";
  EXPECT_GT(estimate, 0.95 * peak);
  EXPECT_LT(estimate, 1.5 * peak);
}

// A folder in a command a message suggests (mca resume DIR) is one word of the shell's command line: as it
// is where that is safe, else quoted so that the shell gives it back unchanged.
TEST(Cli, AFolderInASuggestedCommandIsQuotedForTheShell) {
  EXPECT_EQ(mca::text::shell_word("out/wall_ball-2.x"), "out/wall_ball-2.x");
  EXPECT_EQ(mca::text::shell_word("my run"), "'my run'");
  EXPECT_EQ(mca::text::shell_word(""), "''");
  for (const char* word : {"my run", "it's", "$HOME", "a\\b", "x;y", "*", "tab\there", "''", "new\nline", "-n"}) {
    const Result r = shell("printf '%s' " + mca::text::shell_word(word));
    EXPECT_EQ(r.output, word) << mca::text::shell_word(word);
  }
}

// Paths that are not UTF-8 (file systems take any bytes): a mesh found at one is refused before the run,
// naming the file with its bad bytes shown, because the run writes the path into its scene.toml, which
// TOML wants in UTF-8 (the run went on, and neither its scene.toml nor its checkpoints could be read
// again); a scene file at one runs, and summary.json shows its path with U+FFFD for the bad bytes (the
// run took every step, then failed to write summary.json: a hostile review, 2026-12-06).
TEST(Cli, PathsThatAreNotUtf8AreRefusedOrShown) {
  EXPECT_TRUE(mca::text::is_utf8("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x98\x80"));
  for (const char* bad : {"d\xff", "\xc3", "\xc0\xaf", "\xed\xa0\x80", "\xf4\x90\x80\x80", "\xe2\x82"})
    EXPECT_FALSE(mca::text::is_utf8(bad)) << mca::text::utf8_shown(bad);
  EXPECT_EQ(mca::text::utf8_shown("d\xff/caf\xc3\xa9"), "d\\xff/caf\xc3\xa9");
  const fs::path d = fresh_dir("utf8") / "d\xff";
  const fs::path scene = small_scene(d);
  const Result r = run_mca("run " + mca::text::shell_word(scene.string()) + " --out " +
                           mca::text::shell_word((d / "out").string()) + " --threads 2 --no-vtk");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto j = nlohmann::json::parse(read(d / "out" / "summary.json"));
  EXPECT_NE(j["scene_file"].get<std::string>().find("d\xef\xbf\xbd/small.toml"), std::string::npos) << j["scene_file"];
  mca::test::write_mesh_file(d / "rock.off", mca::test::sphere_mesh(0.2, 2));
  const fs::path mesh_scene = small_scene(d, "[[object]]\nname = \"rock\"\nshape = \"mesh\"\nmesh = \"rock.off\"\n"
                                             "position = [0, 0, 1.5]\n", "rock");
  const Result m = run_mca("run " + mca::text::shell_word(mesh_scene.string()) + " --out " +
                           mca::text::shell_word((d / "rock_out").string()));
  EXPECT_EQ(m.code, 2) << m.output;
  EXPECT_NE(m.output.find("object[1].mesh = \"rock.off\": the file was found at a path that is not UTF-8 text"),
            std::string::npos)
      << m.output;
  EXPECT_NE(m.output.find("d\\xff/rock.off); mca writes the path into the run's scene.toml"), std::string::npos)
      << m.output;
  EXPECT_FALSE(fs::exists(d / "rock_out" / "scene.toml"));
}

// A mesh the scene reads that lies where the run writes and clears (an earlier run's fragment mesh in the
// output folder's fragments/) is refused before the run: the run read it, then wrote over it (a hostile
// review, 2026-12-06).
TEST(Cli, AMeshInsideTheRunsOwnSubfoldersIsRefused) {
  const fs::path d = fresh_dir("own_mesh");
  fs::create_directories(d / "out" / "fragments");
  mca::test::write_mesh_file(d / "out" / "fragments" / "fragment_000.ply", mca::test::sphere_mesh(0.2, 2));
  const std::string before = read(d / "out" / "fragments" / "fragment_000.ply");
  const fs::path scene = small_scene(d, "[[object]]\nname = \"rock\"\nshape = \"mesh\"\n"
                                        "mesh = \"out/fragments/fragment_000.ply\"\nposition = [0, 0, 1.5]\n");
  const Result r = run_mca("run " + scene.string() + " --out " + (d / "out").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("small.toml: object[1].mesh = '" + (d / "out" / "fragments" / "fragment_000.ply").string() +
                          "' lies in '" + (d / "out" / "fragments").string() + "', where the run writes the fragments' "
                          "meshes"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(read(d / "out" / "fragments" / "fragment_000.ply"), before);
  EXPECT_FALSE(fs::exists(d / "out" / "scene.toml"));
  // Beside the output folder's subfolders it is the run's to read.
  fs::rename(d / "out" / "fragments" / "fragment_000.ply", d / "out" / "rock.ply");
  const fs::path beside = small_scene(d, "[[object]]\nname = \"rock\"\nshape = \"mesh\"\nmesh = \"out/rock.ply\"\n"
                                         "position = [0, 0, 1.5]\n", "beside");
  const Result b = run_mca("run " + beside.string() + " --out " + (d / "out").string() + " --threads 2 --no-vtk");
  EXPECT_EQ(b.code, 0) << b.output;
}

// Frame numbers in a message (frames lost before a resume) as runs, and a long list cut short.
TEST(Cli, NumbersInAMessageAreGivenAsRuns) {
  using mca::text::number_runs;
  EXPECT_EQ(number_runs({}), "");
  EXPECT_EQ(number_runs({7}), "7");
  EXPECT_EQ(number_runs({0, 1}), "0, 1");
  EXPECT_EQ(number_runs({0, 1, 2, 5, 7, 8, 9, 10}), "0..2, 5, 7..10");
  EXPECT_EQ(number_runs({1, 3, 5, 7, 9, 10}, 2), "1, 3, and 4 more");
  std::vector<std::int64_t> many(1000000);
  for (std::size_t k = 0; k < many.size(); ++k) many[k] = 2 * static_cast<std::int64_t>(k);
  EXPECT_EQ(number_runs(many).size(), std::string("0, 2, 4, 6, 8, 10, 12, 14, and 999992 more").size());
}

}  // namespace
