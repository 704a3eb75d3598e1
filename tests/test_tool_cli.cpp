// The rost command line: help, and every kind of bad input gives one line
// on stderr naming what and where, exit code 2, and no output files.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "rost/random.hpp"
#include "rost/settings.hpp"
#include "rost/vision/vocabulary.hpp"
#include "test_vision_support.hpp"

using rost::testing::RunResult;
using rost::testing::TempDir;

namespace {

std::string tool() { return std::string("'") + ROST_TOOL + "'"; }

RunResult runRost(const std::string& args) { return rost::testing::runShell(tool() + " " + args); }

// An error run: exit 2, exactly one line on stderr containing `needle`, and
// nothing (not even a staging directory) left in `out` when given.
void expectError(const RunResult& r, const std::string& needle, const std::string& out = {}) {
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "stderr: " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_EQ(r.err.rfind("rost: error: ", 0), 0u) << r.err;
    if (!out.empty() && std::filesystem::exists(out)) {
        for (const auto& e : std::filesystem::directory_iterator(out))
            ADD_FAILURE() << "left behind: " << e.path();
    }
}

} // namespace

TEST(ToolCli, HelpExplainsEveryCommandAndOption) {
    RunResult r = runRost("--help");
    EXPECT_EQ(r.exit_code, 0);
    for (const char* s : {"run", "refine", "vocab", "cameras", "Exit status"})
        EXPECT_NE(r.out.find(s), std::string::npos) << s;
    r = runRost("run --help");
    EXPECT_EQ(r.exit_code, 0);
    for (const char* s : {"-K", "-V", "--alpha", "--beta", "--cell.space", "--cell.time", "--g.space", "--g.time",
                          "--sampler", "now,uniform,agep,exp,uni+now,agep+now,uni+exp,agep+exp", "--eta", "--q",
                          "--budget.refines", "--budget.ms", "--seed", "--max-frames", "--realtime", "--quiet",
                          "--in.topicmodel", "--config", "--checkpoint", "--checkpoint.every", "--resume",
                          "--vocabulary", "--out", "words.csv", "positions.csv", "topics.csv",
                          "perplexity.csv", "surprise.csv", "topicmodel.csv", "overlay.mp4", "summary.png", "camera:N"})
        EXPECT_NE(r.out.find(s), std::string::npos) << "run --help lacks " << s;
    r = runRost("refine --help");
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("--positions"), std::string::npos);
    r = runRost("vocab --help");
    EXPECT_EQ(r.exit_code, 0);
    EXPECT_NE(r.out.find("--words"), std::string::npos);
}

// `rost` links no OpenCV video or image I/O (and no ROS): those libraries
// cost 0.15 s of start-up (docs/tool.md, "Two programs"). rost-vision, which
// runs `rost run`, has them: the check tells the two apart.
TEST(ToolCli, RostStartsWithoutVideoImageIoOrRos) {
    const std::string vision = std::filesystem::path(ROST_TOOL).parent_path() / "rost-vision";
    const RunResult light = rost::testing::runShell("readelf -d " + tool());
    const RunResult heavy = rost::testing::runShell("readelf -d '" + vision + "'");
    if (rost::testing::runShell("command -v readelf").exit_code != 0) GTEST_SKIP() << "no readelf (binutils)";
    ASSERT_EQ(light.exit_code, 0) << light.err;
    ASSERT_EQ(heavy.exit_code, 0) << heavy.err;
    EXPECT_NE(light.out.find("NEEDED"), std::string::npos) << light.out;
    for (const char* lib : {"opencv_videoio", "opencv_imgcodecs", "opencv_features2d", "rost_vision", "rosbag", "roscpp"})
        EXPECT_EQ(light.out.find(lib), std::string::npos) << "rost needs " << lib << ":\n" << light.out;
    EXPECT_NE(heavy.out.find("opencv_videoio"), std::string::npos) << heavy.out;
}

// Without rost-vision beside it (or where the install puts it), `rost run`
// says which program it needs; `rost refine` still works.
TEST(ToolCli, RunWithoutRostVisionNamesTheProgram) {
    TempDir t;
    const std::string alone = t / "rost";
    std::filesystem::copy_file(ROST_TOOL, alone);
    std::filesystem::permissions(alone, std::filesystem::perms::owner_all);
    const RunResult r = rost::testing::runShell("'" + alone + "' run x.mp4 --out '" + (t / "o") + "'");
    expectError(r, "rost-vision is neither beside " + alone, t / "o");
    EXPECT_NE(r.err.find("copy it beside rost"), std::string::npos) << r.err;
    {
        std::FILE* f = std::fopen((t / "w.csv").c_str(), "w");
        ASSERT_NE(f, nullptr);
        std::fputs("0,1,2,3\n1,3,2,1\n", f);
        std::fclose(f);
    }
    const RunResult ok = rost::testing::runShell("'" + alone + "' refine '" + (t / "w.csv") + "' --out '" + (t / "r") +
                                                 "' -K 2 -q");
    EXPECT_EQ(ok.exit_code, 0) << ok.err;
    EXPECT_TRUE(std::filesystem::exists(t / "r/summary.png"));
}

TEST(ToolCli, NoCommandOrUnknownOptionIsAnErrorWithExitCode2) {
    expectError(runRost(""), "subcommand");
    TempDir t;
    expectError(runRost("run x.mp4 --out " + (t / "o") + " --bogus"), "--bogus", t / "o");
}

TEST(ToolCli, InvalidOptionValuesAreNamed) {
    TempDir t;
    cv::imwrite(t / "a.png", cv::Mat(64, 64, CV_8UC3, cv::Scalar(10, 20, 30)));
    const std::string in = t.path() + "/a.png --out " + (t / "o");
    expectError(runRost("run " + in + " -K 0"), "rost: error: -K/--topics = 0, allowed [1, 1024]", t / "o");
    expectError(runRost("run " + in + " --sampler fastest"), "--sampler", t / "o");
    expectError(runRost("run " + in + " --alpha -1"), "alpha", t / "o");
    expectError(runRost("run " + in + " --cell.space 0"), "cell.space", t / "o");
    expectError(runRost("run " + in + " --eta 2"), "eta", t / "o");
    expectError(runRost("run " + in + " --budget.refines 3 --budget.ms 10"), "excludes", t / "o");
    expectError(runRost("run " + in + " -V 100"), "-V 100 is smaller than the 5436 words", t / "o");
    expectError(runRost("run " + in + " --vocabulary " + (t / "none.rostvoc")), "none.rostvoc: cannot open: No such file or directory", t / "o");
    // The bag options name themselves when the input is not a bag.
    expectError(runRost("run " + in + " --topic /camera/image_raw"), "rost: error: --topic needs a bag as the input", t / "o");
    expectError(runRost("run " + in + " --out.bag " + (t / "x.bag")), "rost: error: --out.bag needs a bag as the input", t / "o");
    // The commands' own sizes and counts, where 0 means "all" or "from the input": never below it.
    for (const char* opt : {"--width", "--height", "--max-frames"})
        expectError(runRost("run " + in + " " + opt + " -5"), std::string(opt) + ": expected 0 or more, found '-5'", t / "o");
    rost::testing::writeText(t / "w.csv", "0,1,2\n");
    for (const char* opt : {"--width", "--height"})
        expectError(runRost("refine " + (t / "w.csv") + " --out " + (t / "o") + " " + opt + "=-3"),
                    std::string(opt) + ": expected 0 or more, found '-3'", t / "o");
}

// A file name is printed as the errors quote text (rost::text::printable):
// a newline, an escape or a C1 control in it stays one line on stderr and
// cannot drive the terminal; a note naming a path alike.
TEST(ToolCli, AFileNameWithControlCharactersIsPrintedEscapedOnOneLine) {
    TempDir t;
    const std::string odd = "a\nb\x1b[31m\xC2\x9B" "c";
    const std::string shown = "a\\x0ab\\x1b[31m\\u009bc";
    const RunResult bad = runRost("refine '" + (t / odd) + ".csv' --out " + (t / "o"));
    expectError(bad, shown + ".csv: cannot open: No such file or directory", t / "o");
    EXPECT_EQ(bad.err.find('\x1b'), std::string::npos) << bad.err;
    rost::testing::writeText(t / "w.csv", "0,1,2\n1,2,3\n");
    const RunResult r = runRost("refine " + (t / "w.csv") + " --no-summary --out '" + (t / odd) + "'");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("; outputs in " + t.path() + "/" + shown + "\n"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << r.err;
    EXPECT_TRUE(std::filesystem::exists(t / (odd + "/topics.csv")));
}

// An option missing its value would take the next argument, even another
// option: `--checkpoint --quiet` wrote a checkpoint named "--quiet" and ran
// loudly, `-K --out o` said "--out is required". Refused, naming both.
TEST(ToolCli, AnOptionsValueThatIsAnotherOptionIsRefused) {
    TempDir t;
    rost::testing::writeText(t / "w.csv", "0,1,2\n1,2,3\n");
    const std::string in = (t / "w.csv") + " ";
    expectError(rost::testing::runShell("cd '" + t.path() + "' && " + tool() + " refine " + in + "--checkpoint --quiet --out " +
                                        (t / "o")),
                "rost: error: --checkpoint: needs a value; --quiet is an option (a file of that name: ./--quiet)",
                t / "o");
    EXPECT_FALSE(std::filesystem::exists(t / "--quiet")) << "a checkpoint named after the option";
    // A number's option refuses it before its own range check, and with no
    // file hint (a number is never a file).
    for (const auto& [args, said] : std::vector<std::pair<std::string, std::string>>{
             {"-K --out " + (t / "o"), "--topics: needs a value; --out is an option (see rost --help)"},
             {"--out " + (t / "o") + " --seed=-q", "--seed: needs a value; -q is an option (see rost --help)"},
             {"--out " + (t / "o") + " --width --quiet", "--width: needs a value; --quiet is an option (see rost --help)"}}) {
        const RunResult r = runRost("refine " + in + args);
        expectError(r, said, t / "o");
        EXPECT_EQ(r.err, "rost: error: " + said + "\n");
    }
    expectError(runRost("merge " + in + "--out --threshold 0.5"), "--out: needs a value; --threshold is an option", t / "o");
    // The program's own options too (--version is rost's, not the command's).
    expectError(rost::testing::runShell("cd '" + t.path() + "' && " + tool() + " refine " + in + "--checkpoint --version --out " +
                                        (t / "o")),
                "--checkpoint: needs a value; --version is an option", t / "o");
    EXPECT_FALSE(std::filesystem::exists(t / "--version"));
    // A negative number is a value (refused by its range), and a file named
    // like an option is given with its directory.
    expectError(runRost("refine " + in + "--out " + (t / "o") + " --alpha -1"), "--alpha = -1, allowed (0, 1000000]", t / "o");
    const RunResult r = runRost("refine " + in + "-q --no-summary --out " + (t / "o") + " --checkpoint " + (t / "--quiet"));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(t / "--quiet"));
}

// A file the run cannot write whole (here topics.csv past a 100 KiB file
// size limit, as a full disk would stop it) fails the run naming the file
// and why; nothing reaches --out.
TEST(ToolCli, AnOutputFileThatCannotBeWrittenWholeFailsTheRunNamingIt) {
    TempDir t;
    std::string words;
    for (int i = 0; i < 2000; ++i) {
        words += std::to_string(i);
        for (int j = 0; j < 60; ++j) (words += ',') += std::to_string((i * 7 + j * 13) % 500);
        words += '\n';
    }
    rost::testing::writeText(t / "w.csv", words);
    const RunResult r = rost::testing::runShell("(trap '' XFSZ; ulimit -f 100; " + tool() + " refine " + (t / "w.csv") +
                                                " -K 4 --budget.refines 2 -q --no-summary --out " + (t / "o") + ")");
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_EQ(r.err, "rost: error: " + (t / "o") + "/topics.csv: write failed: File too large\n");
    EXPECT_FALSE(std::filesystem::exists(t / "o"));
}

TEST(ToolCli, UnreadableInputsAreNamed) {
    TempDir t;
    expectError(runRost("run " + (t / "missing.mov") + " --out " + (t / "o")), "missing.mov: cannot open: No such file or directory", t / "o");
    std::filesystem::create_directory(t / "empty");
    expectError(runRost("run " + (t / "empty") + " --out " + (t / "o")), "empty: directory holds no images", t / "o");
    rost::testing::writeText(t / "broken.mov", std::string(10000, '\x42'));
    expectError(runRost("run " + (t / "broken.mov") + " --out " + (t / "o")), "broken.mov: cannot decode video", t / "o");
    expectError(runRost("run '" + t.path() + "/*.jpg' --out " + (t / "o")), "no files match", t / "o");
    // An image cut short (a copy interrupted): named, on rost's one line; libjpeg's and libpng's own
    // lines kept off stderr, and no half-grey frame modelled.
    std::filesystem::create_directory(t / "cut");
    for (const char* ext : {".jpg", ".png"}) {
        std::vector<uint8_t> bytes;
        ASSERT_TRUE(cv::imencode(ext, cv::Mat(64, 64, CV_8UC3, cv::Scalar(10, 200, 30)), bytes));
        const std::string name = std::string("cut/001") + ext;
        rost::testing::writeText(t / name, std::string(bytes.begin(), bytes.begin() + bytes.size() * 2 / 3));
        expectError(runRost("run " + (t / "cut") + " --out " + (t / "o")),
                    name + ": cannot decode image: truncated " + (ext[1] == 'j' ? "JPEG" : "PNG"), t / "o");
        std::filesystem::remove(t / name);
    }
}

// The frame size rule (rost/vision/frame_source.hpp) in the tool: an image too
// small to extract words from is skipped with a line naming it and its size,
// and never sizes the model; with nothing usable left the run exits 2.
TEST(ToolCli, ImagesTooSmallAreSkippedNamedAndNeverSizeTheModel) {
    TempDir t;
    std::filesystem::create_directory(t / "in");
    cv::imwrite(t / "in/a0.png", cv::Mat(1, 1, CV_8UC3, cv::Scalar(10, 20, 30)));
    cv::imwrite(t / "in/a1.png", cv::Mat(1, 300, CV_8UC3, cv::Scalar(10, 20, 30)));
    cv::Mat frame(240, 320, CV_8UC3);
    cv::randu(frame, 0, 255);
    cv::imwrite(t / "in/a2.png", frame);
    cv::imwrite(t / "in/a3.png", cv::Mat(300, 1, CV_8UC3, cv::Scalar(10, 20, 30)));
    cv::imwrite(t / "in/a4.png", frame);
    const RunResult r = runRost("run " + (t / "in") + " --out " + (t / "o") + " -q --no-overlay --no-summary");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("rost: " + (t / "in/a0.png") + ": a 1x1 frame is too small to extract words from"),
              std::string::npos) << r.err;
    EXPECT_NE(r.err.find("in/a1.png: a 300x1 frame is too small"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("in/a3.png: a 1x300 frame is too small"), std::string::npos) << r.err;
    EXPECT_EQ(rost::testing::lines(rost::testing::readText(t / "o/frames.csv")).size(), 3u) << "a header and 2 frames";
    EXPECT_NE(rost::testing::readText(t / "o/run.txt").find("320x240"), std::string::npos);

    std::filesystem::create_directory(t / "small");
    cv::imwrite(t / "small/a.png", cv::Mat(2, 2, CV_8UC3, cv::Scalar(1, 2, 3)));
    expectError(runRost("run " + (t / "small") + " --out " + (t / "o2")),
                "rost: error: images in " + (t / "small") + ": no image large enough to extract words from", t / "o2");
}

TEST(ToolCli, NoCameraSaysSoAndWhatItSees) {
    TempDir t;
    const RunResult r = runRost("run camera:7 --out " + (t / "o"));
    expectError(r, "camera:7: no camera found", t / "o");
    // `rost cameras` lists them on stdout, or says on stderr, as every error, that there is none.
    const RunResult list = runRost("cameras");
    if (list.exit_code == 0) {
        for (const std::string& line : rost::testing::lines(list.out)) EXPECT_EQ(line.rfind("camera:", 0), 0u) << line;
    } else {
        EXPECT_EQ(list.exit_code, 2);
        EXPECT_EQ(list.out, "");
        EXPECT_TRUE(list.err == "rost: error: cameras: no camera found (libcamera sees no camera)\n" ||
                    list.err == "rost: error: cameras: this build of rost has no libcamera support\n")
            << list.err;
    }
}

TEST(ToolCli, RefineNamesTheLineAndColumnOfABadWord) {
    TempDir t;
    rost::testing::writeText(t / "words.csv", "0,1,2,3\n1,4,5\n2,6,99,7\n");
    rost::testing::writeText(t / "positions.csv", "0,0,0,1,1,2,2\n1,3,3,4,4\n2,5,5,6,6,7,7\n");
    expectError(runRost("refine " + (t / "words.csv") + " --positions " + (t / "positions.csv") + " -V 10 --out " +
                     (t / "o")),
                "words.csv:3:5", t / "o");
    rost::testing::writeText(t / "w2.csv", "0,1,2\n1,x\n");
    expectError(runRost("refine " + (t / "w2.csv") + " --out " + (t / "o")), "w2.csv:2:3", t / "o");
    rost::testing::writeText(t / "p2.csv", "0,0,0,1,1\n1,0\n");
    rost::testing::writeText(t / "w3.csv", "0,1,2\n1,3\n");
    expectError(runRost("refine " + (t / "w3.csv") + " --positions " + (t / "p2.csv") + " --out " + (t / "o")), "p2.csv:2",
                t / "o");
    expectError(runRost("refine " + (t / "nothere.csv") + " --out " + (t / "o")), "nothere.csv", t / "o");
    // A positions file that cannot be read is named by its option; a line of one by its place (above).
    const RunResult gone = runRost("refine " + (t / "w3.csv") + " --positions " + (t / "nothere.csv") + " --out " + (t / "o"));
    expectError(gone, "--positions: " + (t / "nothere.csv") + ": cannot open: No such file or directory", t / "o");
    expectError(runRost("refine " + (t / "w3.csv") + " --positions " + t.path() + " --out " + (t / "o")),
                "rost: error: --positions: " + t.path() + ": is a directory, not a file", t / "o");
}

TEST(ToolCli, RefineRunsAWordStreamWithoutPositionsAndWritesItsOutputs) {
    TempDir t;
    std::string words;
    for (int i = 0; i < 30; ++i) {
        words += std::to_string(i);
        for (int j = 0; j < 40; ++j) {
            words += ',';
            words += std::to_string((i < 15 ? 0 : 50) + (i * 7 + j * 3) % 50);
        }
        words += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    const RunResult r = runRost("refine " + (t / "words.csv") + " --out " + (t / "o") + " -K 4 -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "--quiet: " << r.err;
    const auto topics = rost::testing::lines(rost::testing::readText(t / "o/topics.csv"));
    ASSERT_EQ(topics.size(), 30u);
    for (const auto& l : topics) {
        const auto f = rost::testing::fields(l);
        ASSERT_EQ(f.size(), 41u);
        for (std::size_t i = 1; i < f.size(); ++i) ASSERT_LT(std::stoi(f[i]), 4);
    }
    EXPECT_EQ(rost::testing::lines(rost::testing::readText(t / "o/topicmodel.csv")).size(), 4u);
    EXPECT_EQ(rost::testing::lines(rost::testing::readText(t / "o/perplexity.csv")).size(), 31u);
    EXPECT_TRUE(std::filesystem::exists(t / "o/summary.png"));
    // Run again into the same directory without a summary: the earlier run's
    // summary.png could pass for this run's, so it is named; it is kept (whose
    // it is is not known: it may be the user's), as is any other file there.
    const std::string summary = rost::testing::readText(t / "o/summary.png");
    const RunResult again = runRost("refine " + (t / "words.csv") + " --out " + (t / "o") + " -K 3 --no-summary");
    ASSERT_EQ(again.exit_code, 0) << again.err;
    EXPECT_NE(again.err.find("rost: note: not written by this run, kept from before in " + (t / "o") + ": summary.png\n"),
              std::string::npos)
        << again.err;
    EXPECT_EQ(rost::testing::readText(t / "o/summary.png"), summary);
    EXPECT_EQ(rost::testing::lines(rost::testing::readText(t / "o/topicmodel.csv")).size(), 3u);
    // Every file written: no note.
    const RunResult whole = runRost("refine " + (t / "words.csv") + " --out " + (t / "o") + " -K 3");
    ASSERT_EQ(whole.exit_code, 0) << whole.err;
    EXPECT_EQ(whole.err.find("not written by this run"), std::string::npos) << whole.err;
}

TEST(ToolCli, BadTopicModelIsNamedWithLineAndColumn) {
    TempDir t;
    rost::testing::writeText(t / "words.csv", "0,1,2\n1,2,3\n");
    rost::testing::writeText(t / "tm.csv", "1,2,3,4\n5,6,-7,8\n");
    expectError(runRost("refine " + (t / "words.csv") + " -K 2 -V 4 --in.topicmodel " + (t / "tm.csv") + " --out " +
                     (t / "o")),
                "tm.csv:2:5", t / "o");
    rost::testing::writeText(t / "tm.csv", "\n");
    expectError(runRost("refine " + (t / "words.csv") + " -K 2 -V 4 --in.topicmodel " + (t / "tm.csv") + " --out " +
                     (t / "o")),
                "tm.csv: no topic lines (expected 1 to K = 2)", t / "o");
}

// `rost run`'s words are its extractors': a topic model with more words a
// line than they produce was made with another vocabulary (or other word
// options), and is refused rather than read as these words.
TEST(ToolCli, ATopicModelOfAnotherVocabularyIsRefusedByRun) {
    TempDir t;
    cv::imwrite(t / "a.png", cv::Mat(64, 64, CV_8UC3, cv::Scalar(10, 20, 30)));
    std::string row = "1";
    for (int v = 1; v < 6000; ++v) row += ",1";
    rost::testing::writeText(t / "wide.csv", row + "\n" + row + "\n");
    expectError(runRost("run " + (t / "a.png") + " -K 2 --in.topicmodel " + (t / "wide.csv") + " --out " + (t / "o")),
                "rost: error: --in.topicmodel: " + (t / "wide.csv") + " has 6000 words a line, more than the 5436 the "
                "extractors produce (ORB 5000 + intensity 256 + hue 180): a topic model of another vocabulary or other "
                "word options", t / "o");
}

// A fixed topic model: labels are the given topics' numbers (here the
// reverse of the word blocks), the model written is the one given, K and V
// come from the file, and what cannot work is named.
TEST(ToolCli, AFixedTopicModelLabelsInTheGivenTopicsAndKeepsThem) {
    TempDir t;
    std::string words, model[2];
    for (int i = 0; i < 20; ++i) {
        words += std::to_string(i);
        for (int j = 0; j < 30; ++j) (words += ',') += std::to_string((i < 10 ? 0 : 40) + (i * 7 + j * 3) % 40);
        words += "\n";
    }
    for (int v = 0; v < 100; ++v) {  // topic 0 holds words 40-79, topic 1 words 0-39; 80-99 unseen
        for (std::string& m : model) m += v ? "," : "";
        model[0] += std::to_string(v >= 40 && v < 80 ? 5 : 0);
        model[1] += std::to_string(v < 40 ? 5 : 0);
    }
    const std::string given = model[0] + "\n" + model[1] + "\n";
    rost::testing::writeText(t / "words.csv", words);
    rost::testing::writeText(t / "tm.csv", given);
    const std::string run = "refine " + (t / "words.csv") + " --in.topicmodel " + (t / "tm.csv") + " --topicmodel.fixed";
    const RunResult r = runRost(run + " --out " + (t / "o") + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(rost::testing::readText(t / "o/topicmodel.csv"), given) << "the model stays as given";
    int right = 0, all = 0;
    for (const auto& l : rost::testing::lines(rost::testing::readText(t / "o/topics.csv"))) {
        const auto f = rost::testing::fields(l);
        for (std::size_t i = 1; i < f.size(); ++i, ++all) right += std::stoi(f[i]) == (std::stoi(f[0]) < 10 ? 1 : 0);
    }
    EXPECT_EQ(all, 600);
    EXPECT_GE(right, 590) << "labels in the given topics";
    expectError(runRost(run + " -K 3 --out " + (t / "k")), "-K 3 differs from the 2 topics of", t / "k");
    // A merge of many models can hold more topics than a model: the file is named, not -K.
    std::string many;
    for (int k = 0; k < 1025; ++k) many += given.substr(0, given.find('\n') + 1);
    rost::testing::writeText(t / "many.csv", many);
    expectError(runRost("refine " + (t / "words.csv") + " --in.topicmodel " + (t / "many.csv") +
                        " --topicmodel.fixed --out " + (t / "m")),
                "--in.topicmodel: " + (t / "many.csv") + " has 1025 topics (lines), more than the 1024 a model holds",
                t / "m");
    expectError(runRost("refine " + (t / "words.csv") + " --topicmodel.fixed --out " + (t / "n")),
                "needs --in.topicmodel FILE", t / "n");
    // A stream with words beyond the model's 100: another vocabulary's, unless V is given.
    rost::testing::writeText(t / "wide.csv", words + "20,3,120,7\n");
    const std::string wide = "refine " + (t / "wide.csv") + " --in.topicmodel " + (t / "tm.csv") + " --topicmodel.fixed";
    expectError(runRost(wide + " --out " + (t / "w")),
                "rost: error: --in.topicmodel: " + (t / "tm.csv") + " has 100 words a line, but the input's word ids go up "
                "to 120: a fixed topic model labels in its own words (a topic model of another vocabulary? -V 121 labels "
                "the others too, with no counts in it)", t / "w");
    const RunResult v = runRost(wide + " -V 121 --out " + (t / "w") + " -q");
    ASSERT_EQ(v.exit_code, 0) << v.err;
    EXPECT_EQ(rost::testing::readText(t / "w/topicmodel.csv").substr(0, model[0].size() + 1), model[0] + ",");
}

// rost merge: a mission's checkpoint and its topicmodel.csv are the same
// model (every topic meets itself); bad input leaves nothing behind, and an
// --out whose files would replace a model it merges is refused.
TEST(ToolCli, MergeReadsTopicModelsAndCheckpointsAndNamesBadInput) {
    TempDir t;
    std::string words;
    for (int i = 0; i < 20; ++i) {
        words += std::to_string(i);
        for (int j = 0; j < 30; ++j) (words += ',') += std::to_string((i < 10 ? 0 : 40) + (i * 7 + j * 3) % 40);
        words += "\n";
    }
    rost::testing::writeText(t / "words.csv", words);
    const RunResult r = runRost("refine " + (t / "words.csv") + " -K 3 --out " + (t / "a") + " --checkpoint " +
                                (t / "a.ckpt") + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const RunResult m = runRost("merge " + (t / "a/topicmodel.csv") + " " + (t / "a.ckpt") + " --out " + (t / "m"));
    ASSERT_EQ(m.exit_code, 0) << m.err;
    EXPECT_NE(m.err.find("2 models, 6 topics -> 3 global topics (V = 80)"), std::string::npos) << m.err;
    EXPECT_EQ(rost::testing::readText(t / "m/lifting.csv"), "model,local,global\n0,0,0\n0,1,1\n0,2,2\n1,0,0\n1,1,1\n1,2,2\n");
    expectError(runRost("merge " + (t / "a/topicmodel.csv") + " " + (t / "nope.csv") + " --out " + (t / "n")),
                "nope.csv: cannot open", t / "n");
    expectError(runRost("merge " + (t / "a/topicmodel.csv") + " --threshold 2 --out " + (t / "n")),
                "rost: error: --threshold 2 out of range [0, 1]", t / "n");
    // Its files over one of the models it merges: refused, the model kept.
    const std::string model = rost::testing::readText(t / "a/topicmodel.csv");
    expectError(runRost("merge " + (t / "a.ckpt") + " " + (t / "a/topicmodel.csv") + " --out " + (t / "a")),
                "--out: " + (t / "a/topicmodel.csv") + " is an input of this run");
    EXPECT_EQ(rost::testing::readText(t / "a/topicmodel.csv"), model);
    EXPECT_FALSE(std::filesystem::exists(t / "a/lifting.csv"));
    // More global topics than a model holds: written, and a note says that a fixed model can't use them.
    for (const int topics : {1024, 1025}) {  // topics of one word each: each opens a global topic
        std::string wide;
        for (int k = 0; k < topics; ++k)
            for (int v = 0; v < 1025; ++v) wide += (v == k ? "5" : "0") + std::string(v == 1024 ? "\n" : ",");
        rost::testing::writeText(t / "wide.csv", wide);
        const RunResult w = runRost("merge " + (t / "wide.csv") + " --out " + (t / "w"));
        ASSERT_EQ(w.exit_code, 0) << w.err;
        EXPECT_EQ(w.err.find("rost: note: 1025 global topics, more than the 1024 a model holds: "
                             "--topicmodel.fixed cannot label in them") != std::string::npos, topics == 1025) << w.err;
        EXPECT_EQ(w.err.find("rost: note:") != std::string::npos, topics == 1025) << w.err;
    }
}

// The option that sets a setting: "--key" unless the schema names others ("-K,--topics").
std::string optionOf(const rost::SettingSpec& s) {
    if (!s.cli.empty()) return std::string(s.cli.substr(0, s.cli.find(',')));
    std::string o = "--";
    o += s.key;
    return o;
}

// The settings schema is the tool's options: every setting a command takes
// is an option with the schema's default in --help, and `rost config` writes
// every key.
TEST(ToolCli, EverySettingIsAnOptionWithTheSchemasDefault) {
    const RunResult help = runRost("run --help");
    ASSERT_EQ(help.exit_code, 0);
    const RunResult conf = runRost("config");
    ASSERT_EQ(conf.exit_code, 0) << conf.err;
    for (const rost::SettingSpec& s : rost::settingSpecs()) {
        std::string line(s.key);
        line += " =";
        EXPECT_NE(conf.out.find(line), std::string::npos) << "rost config lacks " << s.key;
        if (s.has(rost::setting_flags::Library) || s.key.starts_with("frame.")) continue;
        const std::string option = optionOf(s);
        EXPECT_NE(help.out.find(option), std::string::npos) << "run --help lacks " << option;
        const bool derived = s.has(rost::setting_flags::Derived);
        if (s.type != rost::SettingType::Bool && (!s.def.empty() || derived)) {
            // "  --alpha NUM=0.1   Dirichlet prior ...": the default on the option's line;
            // a derived setting's is where it comes from (the schema's Cores: the machine).
            std::size_t at = help.out.find("  " + option + " ");
            if (at == std::string::npos) at = help.out.find("  " + option + ",");
            ASSERT_NE(at, std::string::npos) << option;
            const std::string optionLine = help.out.substr(at, help.out.find('\n', at) - at);
            std::string shown = "=";
            shown += derived ? (s.has(rost::setting_flags::Cores) ? "the cores" : "from the input") : s.def;
            EXPECT_NE(optionLine.find(shown), std::string::npos) << s.key << " default " << shown << " in: " << optionLine;
        }
    }
}

// The library, the configuration file and the command line agree on every
// default: the file `rost config` prints changes nothing, and setting each
// of its values again on the command line changes nothing either.
TEST(ToolCli, RostConfigsFileAndItsValuesOnTheCommandLineChangeNothing) {
    TempDir t;
    std::string words, positions;
    for (int i = 0; i < 25; ++i) {
        words += std::to_string(i);
        positions += std::to_string(i);
        for (int j = 0; j < 30; ++j) {
            words += ',';
            words += std::to_string((i < 12 ? 0 : 40) + (i * 5 + j * 7) % 40);
            positions += ',';
            positions += std::to_string((j * 37) % 200);
            positions += ',';
            positions += std::to_string((j * 53) % 150);
        }
        words += "\n";
        positions += "\n";
    }
    rost::testing::writeText(t / "w.csv", words);
    rost::testing::writeText(t / "p.csv", positions);
    const RunResult conf = runRost("config");
    ASSERT_EQ(conf.exit_code, 0);
    // Printed with nothing given, every key is commented out; uncommented
    // (all but the ones the tool derives from its input or sets itself, and
    // the budget keys not in force), the file holds every default.
    std::string uncommented;
    int set = 0;
    for (std::size_t at = 0; at < conf.out.size();) {
        const std::size_t end = conf.out.find('\n', at);
        std::string line = conf.out.substr(at, end - at);
        at = end == std::string::npos ? conf.out.size() : end + 1;
        if (line.starts_with("# ") && line.find(" = ") != std::string::npos) {
            const std::string key = line.substr(2, line.find(" = ") - 2);
            const rost::SettingSpec* s = rost::findSetting(key);
            if (s && !s->has(rost::setting_flags::Derived) && !s->has(rost::setting_flags::Library) &&
                !key.starts_with("budget.")) {
                line = line.substr(2);
                ++set;
            }
        }
        uncommented += line + "\n";
    }
    EXPECT_GT(set, 30);
    rost::testing::writeText(t / "all.conf", uncommented);
    std::string explicitOptions;  // every refine option set to its default
    for (const rost::SettingSpec& s : rost::settingSpecs()) {
        if (s.has(rost::setting_flags::Library) || s.has(rost::setting_flags::Derived) || s.def.empty()) continue;
        if (s.group == rost::SettingGroup::Words || s.group == rost::SettingGroup::Runtime) continue;
        if (s.type == rost::SettingType::Bool) continue;
        const std::string option = optionOf(s);
        explicitOptions += ' ';
        explicitOptions += option;
        explicitOptions += ' ';
        explicitOptions += s.def;
    }
    const std::string in = "refine " + (t / "w.csv") + " --positions " + (t / "p.csv") + " -q --no-summary --out ";
    ASSERT_EQ(runRost(in + (t / "a")).exit_code, 0);
    const RunResult b = runRost(in + (t / "b") + " --config " + (t / "all.conf"));
    ASSERT_EQ(b.exit_code, 0) << b.err;
    const RunResult c = runRost(in + (t / "c") + explicitOptions);
    ASSERT_EQ(c.exit_code, 0) << c.err << explicitOptions;
    for (const char* f : {"topics.csv", "perplexity.csv", "surprise.csv", "topicmodel.csv"}) {
        const std::string a = rost::testing::readText(t / "a/" + f);
        EXPECT_FALSE(a.empty()) << f;
        EXPECT_EQ(rost::testing::readText(t / "b/" + f), a) << f;
        EXPECT_EQ(rost::testing::readText(t / "c/" + f), a) << f;
    }
}

// `rost vocab` end to end: the frames it trains on (--max-frames per input,
// --every), the vocabulary's size and provenance note, the same bytes for
// the same seed, and a vocabulary `rost run` then takes.
TEST(ToolCli, VocabTrainsOnTheFramesAskedForAndRunUsesIt) {
    TempDir t;
    std::filesystem::create_directory(t / "in");
    cv::RNG rng(3);
    for (int i = 0; i < 6; ++i) {
        cv::Mat m(120, 160, CV_8UC3);
        rng.fill(m, cv::RNG::UNIFORM, 0, 256);
        ASSERT_TRUE(cv::imwrite(t / ("in/f" + std::to_string(i) + ".png"), m));
    }
    const auto vocab = [&](const std::string& out, const std::string& extra) {
        const RunResult r = runRost("vocab " + (t / "in") + " --out " + (t / out) + " --words 16 -q " + extra);
        EXPECT_EQ(r.exit_code, 0) << r.err;
        rost::vision::Vocabulary v;
        const rost::Status st = rost::vision::Vocabulary::load(t / out, v);
        EXPECT_TRUE(st.ok()) << st.message();
        EXPECT_EQ(v.size(), 16u);
        return v.note();
    };
    for (const auto& [extra, frames] : {std::pair{"--every 1 --max-frames 3", "from 3 frames (every 1)"},
                                        std::pair{"--every 2 --max-frames 5", "from 3 frames (every 2)"},
                                        std::pair{"--every 4", "from 2 frames (every 4)"},
                                        std::pair{"--max-frames 1", "from 1 frame (every 1)"}}) {
        const std::string note = vocab("v.rostvoc", extra);
        EXPECT_NE(note.find(frames), std::string::npos) << extra << ": " << note;
    }
    vocab("a.rostvoc", "--seed 9 --max-frames 2");
    const std::string first = rost::testing::readText(t / "a.rostvoc");
    vocab("a.rostvoc", "--seed 9 --max-frames 2");
    EXPECT_EQ(rost::testing::readText(t / "a.rostvoc"), first) << "the same seed, the same bytes";
    const RunResult run = runRost("run " + (t / "in") + " --vocabulary " + (t / "a.rostvoc") + " -K 2 -q --no-summary --out " +
                                  (t / "o"));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const std::string runTxt = rost::testing::readText(t / "o/run.txt");
    EXPECT_NE(runTxt.find("vocabulary: " + (t / "a.rostvoc") + ", 16 words: k-majority, 16 words, seed 9"), std::string::npos)
        << runTxt;
    EXPECT_NE(runTxt.find("words: V = 452 (orb 16 at 0, "), std::string::npos) << runTxt;
    // --max-frames N reads N frames, not N + 1: a damaged frame after them is never read.
    rost::testing::writeText(t / "in/f6.png", "not an image");
    vocab("b.rostvoc", "--max-frames 6");
    const RunResult past = runRost("vocab " + (t / "in") + " --out " + (t / "c.rostvoc") + " --words 16 -q --max-frames 7");
    EXPECT_EQ(past.exit_code, 2);
    EXPECT_NE(past.err.find("f6.png"), std::string::npos) << past.err;
    // A vocabulary over one of its inputs (the video itself, a frame of the
    // directory it reads) is refused before training, and the input kept.
    const std::string frame = rost::testing::readText(t / "in/f1.png");
    for (const std::string& in : {t / "in/f1.png", t / "in"}) {
        const RunResult over = runRost("vocab " + in + " --out " + (t / "in/f1.png") + " --words 16 -q");
        EXPECT_EQ(over.exit_code, 2) << in;
        EXPECT_NE(over.err.find("--out: " + (t / "in/f1.png")), std::string::npos) << over.err;
        EXPECT_EQ(rost::testing::readText(t / "in/f1.png"), frame) << in;
    }
}

// The budget in force is the one reported, in run.txt and on the start-up
// line: refines, tokens or milliseconds (a token budget was reported as
// that many refines, so a run.txt could not reproduce its run).
TEST(ToolCli, TheBudgetInForceIsTheOneReported) {
    TempDir t;
    std::filesystem::create_directory(t / "in");
    cv::RNG rng(5);
    for (int i = 0; i < 3; ++i) {
        cv::Mat m(96, 128, CV_8UC3);
        rng.fill(m, cv::RNG::UNIFORM, 0, 256);
        ASSERT_TRUE(cv::imwrite(t / ("in/f" + std::to_string(i) + ".png"), m));
    }
    for (const auto& [option, text] : {std::pair{"--budget.tokens 500", "500 tokens"},
                                       std::pair{"--budget.ms 2.5", "2.5 ms"},
                                       std::pair{"--budget.refines 7", "7 refines"}}) {
        const RunResult r = runRost("run " + (t / "in") + " --out " + (t / "o") + " --no-overlay --no-summary -K 4 " + option);
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_NE(r.err.find(std::string("budget ") + text + ", model memory"), std::string::npos) << option << ": " << r.err;
        const std::string runTxt = rost::testing::readText(t / "o/run.txt");
        EXPECT_NE(runTxt.find(std::string("budget ") + text + " per observation"), std::string::npos) << option << ": " << runTxt;
    }
}

// A settings file with the frame size: `rost config` prints it (commented, as
// the tool derives it from its input), `rost refine` takes it, `rost run`
// refuses it by file, line and key (its input sets the frame size).
TEST(ToolCli, AFrameSizeInASettingsFileIsPrintedTakenOrRefusedByCommand) {
    TempDir t;
    rost::testing::writeText(t / "c.conf", "alpha = 0.25\nframe.width = 96\nframe.height = 48\n");
    const RunResult conf = runRost("config --config " + (t / "c.conf"));
    ASSERT_EQ(conf.exit_code, 0) << conf.err;
    // What the file set is set in what is printed, and nothing else: the
    // printed file does what c.conf does (below, for refine and run).
    EXPECT_NE(conf.out.find("\nalpha = 0.25\n"), std::string::npos) << conf.out;
    EXPECT_NE(conf.out.find("\nframe.width = 96\n"), std::string::npos) << conf.out;
    EXPECT_NE(conf.out.find("\nframe.height = 48\n"), std::string::npos) << conf.out;
    EXPECT_NE(conf.out.find("\n# K = 16\n"), std::string::npos) << conf.out;
    rost::testing::writeText(t / "printed.conf", conf.out);
    const RunResult again = runRost("config --config " + (t / "printed.conf"));
    EXPECT_EQ(again.out, conf.out) << "printing the printed file changes it";
    rost::testing::writeText(t / "w.csv", "0,1,2\n1,2,3\n");
    rost::testing::writeText(t / "p.csv", "0,90,40,95,47\n1,1,1,2,2\n");
    for (const char* file : {"c.conf", "printed.conf"}) {
        const RunResult ref = runRost("refine " + (t / "w.csv") + " --positions " + (t / "p.csv") + " --config " +
                                      (t / file) + " -q --no-summary --out " + (t / "r"));
        EXPECT_EQ(ref.exit_code, 0) << ref.err;  // positions up to 95 x 47 lie in the file's 96 x 48 frame
    }
    rost::testing::writeText(t / "narrow.conf", "frame.width = 64\n");
    const RunResult narrow = runRost("refine " + (t / "w.csv") + " --positions " + (t / "p.csv") + " --config " +
                                     (t / "narrow.conf") + " -q --no-summary --out " + (t / "n"));
    EXPECT_EQ(narrow.exit_code, 2);
    EXPECT_NE(narrow.err.find("p.csv:1:3: position (90, 40) outside the frame 64 wide"), std::string::npos) << narrow.err;
    // The command line wins over the file, for the frame size too.
    const RunResult wins = runRost("refine " + (t / "w.csv") + " --positions " + (t / "p.csv") + " --config " +
                                   (t / "c.conf") + " --width 64 -q --no-summary --out " + (t / "n"));
    EXPECT_EQ(wins.exit_code, 2);
    EXPECT_NE(wins.err.find("p.csv:1:3: position (90, 40) outside the frame 64x48"), std::string::npos) << wins.err;
    const RunResult run = runRost("run " + (t / "none") + " --config " + (t / "c.conf") + " --out " + (t / "o"));
    EXPECT_EQ(run.exit_code, 2);
    EXPECT_EQ(run.err, "rost: error: --config: " + (t / "c.conf") +
                           ":2: key 'frame.width' is not a setting of this command (the input sets the frame size; "
                           "--width/--height resize it)\n");
    EXPECT_FALSE(std::filesystem::exists(t / "o"));
}

TEST(ToolCli, ASettingsValueOnTheCommandLineIsCheckedByTheSchema) {
    TempDir t;
    cv::imwrite(t / "a.png", cv::Mat(64, 64, CV_8UC3, cv::Scalar(10, 20, 30)));
    const std::string in = t.path() + "/a.png --out " + (t / "o");
    expectError(runRost("run " + in + " --orb.search fast"), "--orb.search: expected linear or tree, found 'fast'", t / "o");
    expectError(runRost("run " + in + " --thumb.cell 0"), "rost: error: --thumb.cell = 0, allowed [1, 256]", t / "o");
    expectError(runRost("run " + in + " --queue x"), "--queue.slots/--queue: expected an integer, found 'x'", t / "o");
    expectError(runRost("config --alpha 0"), "rost: error: --alpha = 0, allowed (0, 1000000]");
    // Each setting by its option, never by an internal name (strategy.eta, queue_slots).
    expectError(runRost("config --eta 2"), "rost: error: --eta = 2, allowed [0, 1]");
    expectError(runRost("config --queue 0"), "rost: error: --queue.slots/--queue = 0, allowed [1, 65536]");
    expectError(runRost("config --budget.ms 0"), "rost: error: --budget.ms = 0, allowed (0, 3600000]");
    // A write that fails (a full disk) is an error, not exit 0 with half a file.
    expectError(rost::testing::runShell("(" + tool() + " config > /dev/full)"),
                "rost: error: cannot write the settings to standard output: No space left on device");
    // A combination names every option involved.
    expectError(runRost("config --g.time 9 --ring.steps 4"),
                "rost: error: --g.time = 9, allowed [0, 3]; below --ring.steps = 4");
    // `refine` and `run` check the combinations against the input's values, not the library's
    // defaults: a 3-observation stream of 1-pixel cells is a 3-step ring, not a 256-step one
    // too large for a 640 x 480 frame; a frame the positions make 4000 x 4000 is named as such.
    rost::testing::writeText(t / "w.csv", "0,1,2\n1,2,3\n2,3,1\n");
    rost::testing::writeText(t / "p.csv", "0,9,9,0,0\n1,1,1,2,2\n2,3,3,4,4\n");
    const RunResult ok = runRost("refine " + (t / "w.csv") + " --positions " + (t / "p.csv") +
                                 " --cell.space 1 -q --no-summary --out " + (t / "o"));
    EXPECT_EQ(ok.exit_code, 0) << ok.err;
    rost::testing::writeText(t / "p.csv", "0,3999,3999,0,0\n1,1,1,2,2\n2,3,3,4,4\n");
    expectError(runRost("refine " + (t / "w.csv") + " --positions " + (t / "p.csv") + " --cell.space 1 --out " + (t / "o2")),
                "rost: error: --cell.space = 1, allowed at least 4 for the input's frame.width = 4000 by the input's "
                "frame.height = 4000; 16000000 cells a step, at most 1048576",
                t / "o2");
}

// ---- words an observation holds ----------------------------------------------------

namespace {

// 1280 x 720 frames of 16 px blocks in saturated colours: every thumbnail
// pixel gives an intensity and a hue word, and the block corners give ORB
// plenty of keypoints: about 8,200 words a frame, twice the library's
// default max.words.
void writeBlockFrames(const TempDir& t, int frames) {
    rost::Rng rng(11);
    for (int f = 0; f < frames; ++f) {
        cv::Mat img(720, 1280, CV_8UC3);
        for (int y = 0; y < 720; y += 16)
            for (int x = 0; x < 1280; x += 16) {
                const uint32_t c = rng.below(6);
                const cv::Scalar colour(c == 0 || c == 3 ? 255 : 0, c == 1 || c == 3 ? 255 : 40 * (c % 2),
                                        c == 2 || c >= 4 ? 255 : 0);
                img(cv::Rect(x, y, 16, 16)).setTo(colour);
            }
        char name[32];
        std::snprintf(name, sizeof name, "f%02d.png", f);
        cv::imwrite(t / name, img);
    }
}

struct WordCounts {
    long long words = 0, kept = 0;
};
WordCounts framesCsvCounts(const std::string& path) {
    WordCounts w;
    const auto ls = rost::testing::lines(rost::testing::readText(path));
    for (std::size_t i = 1; i < ls.size(); ++i) {
        const auto f = rost::testing::fields(ls[i]);
        w.words += std::stoll(f[2]);
        w.kept += std::stoll(f[7]);
    }
    return w;
}

std::string runTxtLine(const std::string& dir, const std::string& start) {
    for (const auto& l : rost::testing::lines(rost::testing::readText(dir + "/run.txt")))
        if (l.rfind(start, 0) == 0) return l;
    return {};
}

} // namespace

// By default an observation holds every word the extractors can give a frame
// of the input's size; a smaller max.words or cell.capacity drops words, and
// the run says how many, once on stderr (unless --quiet) and in run.txt.
TEST(ToolWords, MaxWordsFollowsTheFrameSizeAndDroppedWordsAreReported) {
    TempDir t;
    writeBlockFrames(t, 3);
    const std::string in = "'" + t.path() + "/*.png' --no-overlay --no-summary";
    RunResult r = runRost("run " + in + " --cell.capacity 4096 --out " + (t / "all"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err.find("dropped"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("max.words 8200"), std::string::npos) << "1000 ORB + 2 x 80 x 45 thumbnail words: " << r.err;
    const WordCounts all = framesCsvCounts(t / "all/frames.csv");
    EXPECT_GT(all.words, 3 * 4096) << "more than the library's default max.words";
    EXPECT_EQ(all.kept, all.words);
    EXPECT_EQ(runTxtLine(t / "all", "words dropped:"), "words dropped: none of " + std::to_string(all.words) +
                                                           " (max.words = 8200, cell.capacity = 4096)");

    r = runRost("run " + in + " --cell.capacity 4096 --max.words 3000 --out " + (t / "obs"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const WordCounts obs = framesCsvCounts(t / "obs/frames.csv");
    EXPECT_EQ(obs.words, all.words);
    EXPECT_EQ(obs.kept, 3 * 3000);
    const std::string dropped = std::to_string(obs.words - obs.kept);
    char pct[32];
    std::snprintf(pct, sizeof pct, "%.3g %%", 100.0 * static_cast<double>(obs.words - obs.kept) / obs.words);
    const std::string note = std::string("rost: note: ") + pct + " of the words were dropped (" + dropped + " of " +
                             std::to_string(obs.words) + ": " + dropped +
                             " beyond max.words = 3000; uniformly subsampled); a larger --max.words keeps them\n";
    EXPECT_NE(r.err.find(note), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("dropped"), r.err.rfind("dropped")) << "said once: " << r.err;
    EXPECT_EQ(runTxtLine(t / "obs", "words dropped:"), "words dropped: " + dropped + " of " +
                                                           std::to_string(obs.words) + " (" + pct + "): " + dropped +
                                                           " beyond max.words = 3000; uniformly subsampled");

    r = runRost("run " + in + " --cell.capacity 8 --out " + (t / "cell"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const WordCounts cell = framesCsvCounts(t / "cell/frames.csv");
    EXPECT_LE(cell.kept, 3 * 8 * 20 * 12) << "240 cells of 8 words a frame";
    const std::string cellDropped = std::to_string(cell.words - cell.kept);
    EXPECT_NE(r.err.find("(" + cellDropped + " of " + std::to_string(cell.words) + ": " + cellDropped +
                         " beyond cell.capacity = 8; uniformly subsampled); a larger --cell.capacity keeps them"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find("beyond max.words"), std::string::npos) << r.err;

    r = runRost("run " + in + " --cell.capacity 8 --quiet --out " + (t / "quiet"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err, "") << "--quiet: no notes";
    EXPECT_EQ(runTxtLine(t / "quiet", "words dropped:"), runTxtLine(t / "cell", "words dropped:"));
}

#ifdef ROST_COUNT_THREADS
namespace {
// w.csv and p.csv in t: `steps` observations of `words` words in a 320 x 240
// frame, the first half's words from 0..29, the second half's from 30..59.
void writeTwoSceneStream(const TempDir& t, int steps, int words) {
    std::string w, p;
    for (int i = 0; i < steps; ++i) {
        w += std::to_string(i);
        p += std::to_string(i);
        for (int j = 0; j < words; ++j) {
            (w += ',') += std::to_string((i < steps / 2 ? 0 : 30) + (i * 11 + j * 7) % 30);
            (p += ',') += std::to_string((j * 37) % 320) + ',' + std::to_string((j * 53) % 240);
        }
        w += "\n";
        p += "\n";
    }
    rost::testing::writeText(t / "w.csv", w);
    rost::testing::writeText(t / "p.csv", p);
}
} // namespace
#endif

// `--threads 1` is one thread from start to end: no reader beside the words,
// no zeroing helper, no worker, no thread drawing summary.png (the tool's
// whole command, what a user pinning rost to one core of a board expects).
// With two, the reader, the worker and the summary's thread are started, and
// the files, summary.png included, are the same bytes.
TEST(ToolCli, RefineOnOneThreadStartsNoThreadAndOnTwoGivesTheSameFiles) {
#ifndef ROST_COUNT_THREADS
    GTEST_SKIP() << "the thread counter is not built under a sanitizer";
#else
    TempDir t;
    writeTwoSceneStream(t, 40, 60);
    const auto threadsStarted = [&](int threads, const std::string& out) {
        const RunResult r = rost::testing::runShell("ROST_TEST_THREADS_FILE=" + (t / (out + ".threads")) +
                                                    " LD_PRELOAD='" + ROST_COUNT_THREADS + "' " + tool() + " refine " +
                                                    (t / "w.csv") + " --positions " + (t / "p.csv") + " -K 4 -q --threads " +
                                                    std::to_string(threads) + " --out " + (t / out));
        EXPECT_EQ(r.exit_code, 0) << r.err;
        const std::string counted = rost::testing::readText(t / (out + ".threads"));
        EXPECT_FALSE(counted.empty()) << "the counter wrote nothing: was it loaded?";
        return counted.empty() ? -1 : std::stoi(counted);
    };
    EXPECT_EQ(threadsStarted(1, "one"), 0);
    EXPECT_GE(threadsStarted(2, "two"), 3) << "the positions' reader, the worker, summary.png";
    for (const char* f : {"topics.csv", "perplexity.csv", "surprise.csv", "topicmodel.csv", "summary.png"}) {
        const std::string one = rost::testing::readText(t / "one/" + f);
        EXPECT_FALSE(one.empty()) << f;
        EXPECT_EQ(rost::testing::readText(t / "two/" + f), one) << f;
    }
#endif
}

// A process that may start some of the refinement's threads but not all (a
// process or memory limit) stops with one error naming the setting, exit 2,
// and no staging directory left: it aborted (std::terminate, a joinable
// std::thread destroyed) before. The counter's limit lets the positions'
// reader and one worker of --threads 4 start.
TEST(ToolCli, ThreadsThatCannotAllStartAreAnErrorNotAnAbort) {
#ifndef ROST_COUNT_THREADS
    GTEST_SKIP() << "the thread counter is not built under a sanitizer";
#else
    TempDir t;
    writeTwoSceneStream(t, 20, 40);
    for (const int limit : {0, 2}) {
        const std::string out = "out" + std::to_string(limit);
        std::filesystem::create_directory(t / out);
        const RunResult r = rost::testing::runShell("ROST_TEST_THREADS_LIMIT=" + std::to_string(limit) + " LD_PRELOAD='" +
                                                    ROST_COUNT_THREADS + "' " + tool() + " refine " + (t / "w.csv") +
                                                    " --positions " + (t / "p.csv") + " -K 4 -q --threads 4 --out " +
                                                    (t / out));
        EXPECT_EQ(r.exit_code, 2) << r.err;
        EXPECT_NE(r.err.find("rost: error: engine: cannot start the refinement's threads (threads = 4; lower it): "),
                  std::string::npos)
            << r.err;
        EXPECT_TRUE(std::filesystem::is_empty(t / out)) << "limit " << limit << ": something was left in the output";
    }
#endif
}

// summary.png's surprise curve is filled below it, within its plot: the
// fill's colour (a light blue blended 0.55 over white) covers much of the
// plot's box and nothing outside it (the box's place is the summary's layout:
// 1,600 pixels wide, the perplexity plot above from y = 78, 230 high, a gap
// of 38, the surprise plot 190 high, from x = 96 to 36 from the right edge),
// a timestamp that goes back included (drawn at the plot's left edge).
TEST(ToolCli, SummarysSurpriseFillLiesInItsPlot) {
    TempDir t;
    std::string words;
    for (int i = 0; i < 60; ++i) {
        words += std::to_string(i == 45 ? -500 : i);
        for (int j = 0; j < 40; ++j) (words += ',') += std::to_string((i < 30 ? 0 : 25) + (i * 13 + j * 7) % 25);
        words += "\n";
    }
    rost::testing::writeText(t / "w.csv", words);
    const RunResult r = runRost("refine " + (t / "w.csv") + " -K 4 -q --out " + (t / "o"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const cv::Mat img = cv::imread(t / "o/summary.png");
    ASSERT_EQ(img.cols, 1600);
    const cv::Rect box(96, 78 + 230 + 38, 1600 - 96 - 36, 190);
    int inside = 0, outside = 0, curveBeside = 0;
    for (int y = 0; y < img.rows; ++y)
        for (int x = 0; x < img.cols; ++x) {
            const cv::Vec3b p = img.at<cv::Vec3b>(y, x);  // B, G, R: 0.55 * (190, 190, 240) + 0.45 * 255
            if (p == cv::Vec3b(219, 219, 247)) ++(box.contains({x, y}) ? inside : outside);
            // The curve's own colour left or right of the plot, in its rows (past
            // the pixel its 2-pixel-thick line reaches beyond its first and last point).
            if (p == cv::Vec3b(40, 39, 214) && y >= box.y && y < box.y + box.height &&
                (x < box.x - 2 || x >= box.x + box.width + 2))
                ++curveBeside;
        }
    EXPECT_GT(inside, box.area() / 100) << "the fill below the surprise curve (its peak at the change of topics)";
    EXPECT_EQ(outside, 0);
    EXPECT_EQ(curveBeside, 0) << "the observation whose timestamp goes back is drawn at the plot's edge";
}
