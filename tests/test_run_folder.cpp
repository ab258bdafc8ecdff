// What a run folder holds across runs and resumes: a resume continues only its own run's checkpoint, a new
// run leaves nothing of an earlier one, the rate of a resumed session is its own.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "io/checkpoint.hpp"
#include "shell.hpp"
#include "io/output_files.hpp"
#include "small_scene.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;
using test::Result;
using test::run_mca;
using test::shell;
using test::TempDir;
using test::read;
using test::small_scene;

std::vector<fs::path> checkpoints(const fs::path& out) {
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(out / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  return cks;
}

// A checkpoint of another scene copied into a run folder is refused before anything is written: it would
// put that scene's frames, stats and summary beside the folder's own.
TEST(RunFolder, ResumeRefusesACheckpointOfAnotherScene) {
  TempDir t;
  const fs::path a = t.path() / "a", b = t.path() / "b";
  ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + a.string() + " -q --checkpoint-every 2").code, 0);
  const fs::path other = small_scene(t.path(), "", "other");
  std::string text = read(other);
  text.replace(text.find("velocity = [0, 60, 0]"), 21, "velocity = [0, 50, 0]");
  std::ofstream(other) << text;
  ASSERT_EQ(run_mca("run " + other.string() + " --out " + b.string() + " -q --checkpoint-every 2").code, 0);
  for (const fs::path& ck : checkpoints(a)) fs::remove(ck);
  const fs::path foreign = a / "checkpoints" / checkpoints(b).front().filename();
  fs::copy_file(checkpoints(b).front(), foreign);
  fs::remove(a / "summary.json");
  const std::string stats = read(a / "stats.csv");
  const Result r = run_mca("resume " + a.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(foreign.string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find((a / "scene.toml").string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("another scene"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("name = \"small\""), std::string::npos) << "the first key that differs: " << r.output;
  EXPECT_NE(r.output.find("remove it from"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(a / "summary.json"));
  EXPECT_EQ(read(a / "stats.csv"), stats);
  // A folder without its scene.toml: whose checkpoint it is cannot be told.
  fs::remove(a / "scene.toml");
  const Result missing = run_mca("resume " + a.string() + " -q");
  EXPECT_EQ(missing.code, 2) << missing.output;
  EXPECT_NE(missing.output.find("scene.toml is missing"), std::string::npos) << missing.output;
  // One that is a folder is named as such (it was "missing").
  fs::create_directory(a / "scene.toml");
  const Result folder = run_mca("resume " + a.string() + " -q");
  EXPECT_EQ(folder.code, 2) << folder.output;
  EXPECT_NE(folder.output.find("scene.toml is a directory, not the run's scene file"), std::string::npos)
      << folder.output;
  // The folder's own checkpoint resumes (twice: the checkpoints a resume writes carry the scene as read back).
  for (const fs::path& ck : checkpoints(b)) fs::remove(ck);
  ASSERT_EQ(run_mca("run " + other.string() + " --out " + b.string() + " -q --checkpoint-every 1").code, 0);
  std::vector<fs::path> own = checkpoints(b);
  ASSERT_EQ(own.size(), 2u);
  fs::remove(own.back());  // frame 4; resume from frame 3
  Result ok = run_mca("resume " + b.string() + " -q");
  ASSERT_EQ(ok.code, 0) << ok.output;
  own = checkpoints(b);
  fs::remove(own.back());
  ok = run_mca("resume " + b.string() + " -q");
  EXPECT_EQ(ok.code, 0) << ok.output;
}

// A new run in a folder removes what mca wrote there before (here: another run's fragments.csv, pictures
// and plots, which this run does not write) and leaves every other file alone.
TEST(RunFolder, NewRunRemovesAnEarlierRunsFragmentsAndPictures) {
  TempDir t;
  const fs::path out = t.path() / "out";
  // An earlier run (its scene.toml: the folder holds a run of mca), and what a rendered one left.
  ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() + " -q --steps 2").code, 0);
  fs::create_directories(out / "render");
  for (const char* f : {"fragments.csv", "render/frame_000000.png", "render/frame_000031.png", "render/video.mp4",
                        "render/contact_sheet.png", "render/energies.png", "render/broken_links.png",
                        "render/fragment_masses.png", "render/render.json"})
    std::ofstream(out / f) << "earlier run\n";
  std::ofstream(out / "notes.txt") << "mine\n";
  std::ofstream(out / "render" / "frame_sketch.jpg") << "mine\n";
  const Result r = run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() + " -q --steps 2");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(read(out / "notes.txt"), "mine\n");
  EXPECT_EQ(read(out / "render" / "frame_sketch.jpg"), "mine\n");
  for (const char* f : {"render/frame_000000.png", "render/frame_000031.png", "render/video.mp4",
                        "render/contact_sheet.png", "render/energies.png", "render/broken_links.png",
                        "render/fragment_masses.png", "render/render.json"})
    EXPECT_FALSE(fs::exists(out / f)) << f;
  EXPECT_NE(read(out / "fragments.csv"), "earlier run\n");
  // Once the pictures are gone, so is their empty folder.
  fs::remove(out / "render" / "frame_sketch.jpg");
  std::ofstream(out / "render" / "video.mp4") << "earlier run\n";
  ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() + " -q --steps 2").code, 0);
  EXPECT_FALSE(fs::exists(out / "render"));
  // A run killed before its end writes no fragments.csv: the earlier run's must not stand beside its frames.
  std::ofstream(out / "fragments.csv") << "earlier run\n";
  const Result killed = shell("timeout -s KILL 3 " + std::string(MCA_BINARY) + " run " +
                              small_scene(t.path()).string() + " --out " + out.string() + " -q --no-vtk --duration 100");
  ASSERT_NE(killed.code, 0) << killed.output;
  ASSERT_TRUE(fs::exists(out / "stats.csv"));
  EXPECT_FALSE(fs::exists(out / "fragments.csv"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

// Every file under `dir` with its bytes.
std::map<std::string, std::string> folder_contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = read(e.path());
  return files;
}

// What differs between two folder_contents, a file a line ("" when nothing does).
std::string changes(const std::map<std::string, std::string>& before, const std::map<std::string, std::string>& after) {
  std::string out;
  for (const auto& [name, bytes] : before) {
    const auto it = after.find(name);
    if (it == after.end()) out += "gone: " + name + "\n";
    else if (it->second != bytes) out += "changed: " + name + "\n";
  }
  for (const auto& [name, bytes] : after)
    if (!before.count(name)) out += "new: " + name + "\n";
  return out;
}

// A run or a resume refused because an earlier run's file cannot be removed (an immutable file, a folder
// the user may not write: played here by a preloaded fault, which holds as root too) removed the files
// before it first, the summary and stats among them: the folder was left as neither run. They are set
// aside, all or none, and put back when the session stops before it writes anything of its own (a scene
// file that cannot be written, a renderer that cannot start).
TEST(RunFolder, AnEarlierRunThatCannotBeRemovedIsLeftWhole) {
  TempDir t;
  const fs::path out = t.path() / "out";
  const std::string run = "run " + small_scene(t.path()).string() + " --out " + out.string() + " -q";
  ASSERT_EQ(run_mca(run + " --checkpoint-every 2").code, 0);
  fs::create_directories(out / "render");
  std::ofstream(out / "render" / "energies.png") << "a plot\n";
  const auto before = folder_contents(out);
  ASSERT_TRUE(before.count("summary.json") && before.count("frames/automata_000002.vtu")) << before.size();
  Result r = test::run_mca_with_fault("MCA_TEST_PINNED_AT", "frames/automata_000002.vtu", run);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find(fmt::format("cannot remove '{}', an output of an earlier run in this folder (Operation not "
                                      "permitted); nothing was removed",
                                      (out / "frames" / "automata_000002.vtu").string())),
            std::string::npos)
      << r.output;
  EXPECT_EQ(changes(before, folder_contents(out)), "");
  // The scene file cannot be written (a full disk at it): the earlier run is put back.
  r = test::run_mca_full_at("scene.toml", run);
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_EQ(changes(before, folder_contents(out)), "");
  // A resume with steps left sets aside the run's end and its plots: one that cannot be removed leaves them all.
  const auto cks = checkpoints(out);
  ASSERT_GE(cks.size(), 2u);
  fs::remove(cks.back());
  const auto resumable = folder_contents(out);
  r = test::run_mca_with_fault("MCA_TEST_PINNED_AT", "fragments.csv", "resume " + out.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("fragments.csv', an output of an earlier run in this folder (Operation not permitted); "
                          "nothing was removed"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(changes(resumable, folder_contents(out)), "");
  // A resume rewrites its collections and stats (without the entries past its checkpoint) before it
  // removes the earlier end: one stopped between the two (here its stats cannot be written) had left the
  // collections cut back beside the earlier run's summary; they are set aside with the end, and go back.
  r = test::run_mca_full_at("stats.csv", "resume " + out.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("stats.csv"), std::string::npos) << r.output;
  EXPECT_EQ(changes(resumable, folder_contents(out)), "");
  // A rendered resume sets aside the pictures it draws again (the frames past the checkpoint, the video, the
  // sheet) with the rest: one that cannot be removed leaves them all (it had removed the frames first).
  {
    const fs::path drawn = t.path() / "drawn";
    ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + drawn.string() +
                      " -q --checkpoint-every 2 --render --render-size 64x48")
                  .code,
              0);
    fs::remove(checkpoints(drawn).back());
    const auto rendered = folder_contents(drawn);
    ASSERT_TRUE(rendered.count("render/frame_000004.png") && rendered.count("render/video.mp4")) << rendered.size();
    r = test::run_mca_with_fault("MCA_TEST_PINNED_AT", "render/video.mp4", "resume " + drawn.string() + " -q");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_EQ(changes(rendered, folder_contents(drawn)), "");
  }
  // Without the fault both go through.
  ASSERT_EQ(run_mca("resume " + out.string() + " -q").code, 0);
  EXPECT_FALSE(fs::exists(out / "render" / "energies.png"));
  ASSERT_EQ(run_mca(run).code, 0);
  EXPECT_FALSE(fs::exists(out / "checkpoints" / cks.front().filename()));
}

// A session killed while it set an earlier run's files aside left them under names the next session took
// for a dead process's temporaries and removed: a resume then lost the frames and stats before the
// checkpoint (exit 0, a warning), or found no checkpoint. The next session puts them back (over what the
// killed one wrote at their names: its scene file) and says so, whatever their process id (another pid
// namespace's, or one reused since, looks alive); where the killed session had begun to remove them (its
// marker in the folder), the rest go. A user's files of such names are left alone.
TEST(RunFolder, FilesAKilledSessionSetAsideGoBack) {
  TempDir t;
  const fs::path out = t.path() / "out", whole = t.path() / "whole";
  const std::string scene = small_scene(t.path()).string();
  ASSERT_EQ(run_mca("run " + scene + " --out " + whole.string() + " -q").code, 0);
  ASSERT_EQ(run_mca("run " + scene + " --out " + out.string() + " -q --checkpoint-every 2").code, 0);
  fs::remove(checkpoints(out).back());
  std::ofstream(out / "notes.txt.1.2.mca-aside") << "mine\n";
  std::ofstream(out / "stats.csv.20240101.1.aside") << "mine\n";
  const auto resumable = folder_contents(out);
  // As a killed session leaves them, its pid that of this test (alive) or of no process.
  const std::string alive = "." + std::to_string(::getpid()) + ".", dead = ".4194305.";
  int n = 0;
  for (const char* name : {"stats.csv", "frames/automata_000001.vtu", "checkpoints/frame_000002.mcack",
                           "automata.pvd", "scene.toml"}) {
    const std::string pid = n % 2 ? dead : alive;
    fs::rename(out / name, out / (std::string(name) + pid + std::to_string(n) + ".mca-aside"));
    ++n;
  }
  std::ofstream(out / "scene.toml") << "# the killed session's scene\n";
  // It had also written a file where the earlier run had none (its rendering's options, which would have a
  // resume of this unrendered run draw): it goes, with its marker.
  fs::create_directories(out / "render");
  std::ofstream(out / "render" / "render.json") << "{}\n";
  std::ofstream(out / "render" / ("render.json" + dead + "5.mca-new"));
  const Result r = run_mca("resume " + out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("mca: 5 files of the run in " + out.string() + " that a session stopped before it began had "
                          "set aside are back at their names"),
            std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("mca: 1 file that a session stopped before its run began had written in " + out.string() +
                          " is removed"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out / "render" / "render.json"));
  EXPECT_FALSE(fs::exists(out / "render" / ("render.json" + dead + "5.mca-new")));
  EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
  EXPECT_EQ(nlohmann::json::parse(read(out / "summary.json"))["state_hash"],
            nlohmann::json::parse(read(whole / "summary.json"))["state_hash"]);
  EXPECT_EQ(read(out / "stats.csv"), read(whole / "stats.csv"));
  EXPECT_EQ(read(out / "scene.toml"), resumable.at("scene.toml"));
  EXPECT_EQ(read(out / "notes.txt.1.2.mca-aside"), "mine\n");
  EXPECT_EQ(read(out / "stats.csv.20240101.1.aside"), "mine\n");
  // Killed as it removed them (its marker there): what is left of them goes, the files at their names stay.
  const std::string summary = read(out / "summary.json");
  std::ofstream(out / "summary.json.4194305.7.mca-aside") << "the earlier run's\n";
  std::ofstream(out / ".mca-committing.4194305");
  // (A file it wrote where the earlier run had none is its run's now: its marker goes, the file stays.)
  std::ofstream(out / "stats.csv.4194305.9.mca-new");
  const Result again = run_mca("resume " + out.string());
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_NE(again.output.find("mca: 1 file in " + out.string() + " that a session had set aside to remove is removed"),
            std::string::npos)
      << again.output;
  EXPECT_FALSE(fs::exists(out / ".mca-committing.4194305"));
  for (const auto& e : fs::recursive_directory_iterator(out))
    EXPECT_FALSE(e.path().filename().string().ends_with(".4194305.7.mca-aside")) << e.path();
  EXPECT_FALSE(fs::exists(out / "stats.csv.4194305.9.mca-new"));
  EXPECT_TRUE(fs::exists(out / "stats.csv"));
  // One that cannot be put back stops the session, naming it and the fix (left aside, it would later be put
  // back over a newer run's file).
  fs::rename(out / "fragments.csv", out / "fragments.csv.4194305.8.mca-aside");
  fs::create_directories(out / "fragments.csv" / "mine");
  const Result stuck = run_mca("resume " + out.string());
  EXPECT_EQ(stuck.code, 2) << stuck.output;
  EXPECT_NE(stuck.output.find("cannot put back '" + (out / "fragments.csv.4194305.8.mca-aside").string()), std::string::npos)
      << stuck.output;
  EXPECT_TRUE(fs::exists(out / "fragments.csv.4194305.8.mca-aside"));
  // In a folder that holds no run of mca, names of that form are a user's: left alone, and the folder refused.
  const fs::path mine = t.path() / "mine";
  fs::create_directories(mine);
  std::ofstream(mine / "summary.json") << "mine\n";
  std::ofstream(mine / "summary.json.1.2.mca-aside") << "my backup\n";
  const Result refused = run_mca("run " + scene + " --out " + mine.string() + " -q");
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_EQ(read(mine / "summary.json"), "mine\n");
  EXPECT_EQ(read(mine / "summary.json.1.2.mca-aside"), "my backup\n");
}

// What a killed session wrote where the earlier run had none is marked (NAME.<pid>.<n>.mca-new) until its
// commit. A session killed in an empty folder after marking its scene file, before writing it, left only
// the marker: the next run took the folder for no run's, kept the marker, and a later session removed that
// run's scene.toml by it; killed after writing render.json but before its scene file, the folder was
// refused for ever. The scene file is written first now, and a marked scene file makes the folder a run's.
// A marker whose removal at commit fails keeps the commit's own marker, so that the next session removes
// it and not the file; only an empty regular file is a marker.
TEST(RunFolder, FilesAKilledSessionWroteWhereTheEarlierRunHadNoneGo) {
  TempDir t;
  const std::string scene = small_scene(t.path()).string();
  const std::string dead = ".4194305.";
  // Killed after marking its scene file: the marker alone.
  const fs::path empty = t.path() / "empty";
  fs::create_directories(empty);
  std::ofstream(empty / ("scene.toml" + dead + "0.mca-new"));
  ASSERT_EQ(run_mca("run " + scene + " --out " + empty.string() + " -q").code, 0);
  for (const auto& e : fs::recursive_directory_iterator(empty))
    EXPECT_FALSE(e.path().filename().string().ends_with(".mca-new")) << e.path();
  const std::string written = read(empty / "scene.toml");
  ASSERT_EQ(run_mca("run " + scene + " --out " + empty.string() + " -q").code, 0);
  EXPECT_EQ(read(empty / "scene.toml"), written);
  // Killed after writing its scene file and render.json into an empty folder: both go, and render/.
  const fs::path killed = t.path() / "killed";
  fs::create_directories(killed / "render");
  fs::copy_file(empty / "scene.toml", killed / "scene.toml");
  std::ofstream(killed / ("scene.toml" + dead + "0.mca-new"));
  std::ofstream(killed / "render" / "render.json") << "{}\n";
  std::ofstream(killed / "render" / ("render.json" + dead + "1.mca-new"));
  const Result r = run_mca("run " + scene + " --out " + killed.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("mca: 2 files that a session stopped before its run began had written in " +
                          killed.string() + " are removed"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(killed / "render")) << "render/ was the killed session's";
  // Not a marker, whatever its name: a file with something in it, a folder; their files stay.
  std::ofstream(killed / ("stats.csv" + dead + "2.mca-new")) << "mine\n";
  fs::create_directories(killed / ("summary.json" + dead + "3.mca-new"));
  const std::string stats = read(killed / "stats.csv");
  ASSERT_EQ(run_mca("run " + scene + " --out " + killed.string() + " -q").code, 0);
  EXPECT_TRUE(fs::exists(killed / "summary.json"));
  EXPECT_EQ(read(killed / ("stats.csv" + dead + "2.mca-new")), "mine\n");
  EXPECT_EQ(read(killed / "stats.csv"), stats);
  // An empty file of a marker's name for a run file, in a folder that held no run yet, is no session's
  // (one killed there marked its scene file first): kept, a later session removed the run's file by it,
  // here the stats a resume reads back. The first run removes those of the table's names.
  const fs::path fresh = t.path() / "fresh";
  fs::create_directories(fresh / "frames");
  std::ofstream(fresh / ("stats.csv" + dead + "4.mca-new"));
  std::ofstream(fresh / "frames" / ("automata_000001.vtu" + dead + "5.mca-new"));
  std::ofstream(fresh / ("notes.txt" + dead + "6.mca-new"));
  ASSERT_EQ(run_mca("run " + scene + " --out " + fresh.string() + " -q --checkpoint-every 2").code, 0);
  EXPECT_FALSE(fs::exists(fresh / ("stats.csv" + dead + "4.mca-new")));
  EXPECT_FALSE(fs::exists(fresh / "frames" / ("automata_000001.vtu" + dead + "5.mca-new")));
  EXPECT_TRUE(fs::exists(fresh / ("notes.txt" + dead + "6.mca-new")));
  fs::remove(checkpoints(fresh).back());
  const Result resumed = run_mca("resume " + fresh.string());
  ASSERT_EQ(resumed.code, 0) << resumed.output;
  EXPECT_EQ(resumed.output.find("removed"), std::string::npos) << resumed.output;
  EXPECT_EQ(resumed.output.find("warning"), std::string::npos) << resumed.output;
  // A new run killed after it set such a marker aside (with its own scene file written): the next session
  // puts the marker back, as the folder was, and its run removes it; no file set aside is left behind.
  const fs::path again = t.path() / "again";
  fs::create_directories(again);
  std::ofstream(again / ("stats.csv" + dead + "7.mca-new" + dead + "8.mca-aside"));
  fs::copy_file(empty / "scene.toml", again / "scene.toml");  // (the killed session's, by mca)
  std::ofstream(again / ("scene.toml" + dead + "9.mca-new"));
  const Result after_kill = run_mca("run " + scene + " --out " + again.string());
  ASSERT_EQ(after_kill.code, 0) << after_kill.output;
  EXPECT_NE(after_kill.output.find("1 file of the run in " + again.string() +
                                   " that a session stopped before it began had set aside is back at its name"),
            std::string::npos)
      << after_kill.output;
  for (const auto& e : fs::recursive_directory_iterator(again)) {
    EXPECT_FALSE(e.path().filename().string().ends_with(".mca-aside")) << e.path();
    EXPECT_FALSE(e.path().filename().string().ends_with(".mca-new")) << e.path();
  }
  // A marker the commit cannot remove (here every .mca-new pinned) keeps the commit's marker: the next
  // session removes the marker, and the run's render.json stays.
  const fs::path rendered = t.path() / "rendered";
  const Result pinned =
      test::run_mca_with_fault("MCA_TEST_PINNED_AT", ".mca-new", "run " + scene + " --out " + rendered.string() +
                                                                   " -q --render --render-size 64x48");
  ASSERT_EQ(pinned.code, 0) << pinned.output;
  std::size_t committing = 0;
  for (const auto& e : fs::directory_iterator(rendered))
    committing += e.path().filename().string().starts_with(".mca-committing.");
  EXPECT_EQ(committing, 1u);
  const Result next = run_mca("run " + scene + " --out " + rendered.string() + " -q --render --render-size 64x48");
  ASSERT_EQ(next.code, 0) << next.output;
  EXPECT_TRUE(fs::exists(rendered / "render" / "render.json"));
  for (const auto& e : fs::recursive_directory_iterator(rendered)) {
    EXPECT_FALSE(e.path().filename().string().ends_with(".mca-new")) << e.path();
    EXPECT_FALSE(e.path().filename().string().starts_with(".mca-committing.")) << e.path();
  }
}

// The rate of a resumed run is its own steps over its own wall time: the earlier sessions' wall time (here
// made a million seconds) must not divide it. (A wall time of a million seconds is one a checkpoint may hold.)
TEST(RunFolder, ResumedRateIsTheSessionsOwn) {
  TempDir t;
  const fs::path out = t.path() / "out";
  ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() +
                    " -q --no-vtk --checkpoint-every 2").code, 0);
  const std::vector<fs::path> cks = checkpoints(out);
  ASSERT_EQ(cks.size(), 2u);
  fs::remove(cks.back());
  io::Checkpoint cp = io::read_checkpoint(cks.front());
  cp.wall_seconds = 1e6;
  io::write_checkpoint(cks.front(), cp);
  const Result r = run_mca("resume " + out.string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto j = nlohmann::json::parse(read(out / "summary.json"));
  EXPECT_GE(j["wall_seconds"].get<double>(), 1e6);
  const double session = j["session_wall_seconds"].get<double>();
  const auto steps = j["session_steps"].get<std::int64_t>();
  EXPECT_EQ(steps, j["steps"].get<std::int64_t>() - cp.state.step);
  ASSERT_GT(session, 0);
  EXPECT_LT(session, 1e3);
  EXPECT_DOUBLE_EQ(j["automaton_steps_per_second"].get<double>(),
                   static_cast<double>(steps) * j["automata"].get<double>() / session);
  // Its scene is the folder's scene.toml (it named the checkpoint's embedded scene), and its checkpoint is named.
  EXPECT_EQ(j["scene_file"], (out / "scene.toml").string());
  EXPECT_EQ(j["resumed_from"], cks.front().string());
}

// Two runs into one folder at once mixed their frames, stats and summaries, and both exited 0: while one
// mca holds the folder's lock (here the test, as a run would), a run and a resume into it are refused,
// naming the folder, and nothing is written.
TEST(RunFolder, ASecondRunIntoAFolderInUseIsRefused) {
  TempDir t;
  const fs::path out = t.path() / "busy";
  ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() + " -q --checkpoint-every 2").code, 0);
  const std::string stats = read(out / "stats.csv");
  {
    const io::OutputLock held(out);
    Result r = run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() + " -q");
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.output.find("another mca run or resume is writing into"), std::string::npos) << r.output;
    r = run_mca("resume " + out.string() + " -q");
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.output.find("another mca run or resume is writing into"), std::string::npos) << r.output;
    EXPECT_EQ(read(out / "stats.csv"), stats);
  }
  // Released with its holder: a run goes ahead.
  EXPECT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() + " -q").code, 0);
}

}  // namespace
}  // namespace mca
