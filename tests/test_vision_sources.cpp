// Frame sources: image directories and globs, video files, joined inputs,
// cameras, and the one-line errors for inputs that cannot be read.

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <limits>
#include <tuple>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "rost/vision/frame_source.hpp"
#include "rost/vision/mission.hpp"
#include "rost/vision/presentation_clock.hpp"
#include "test_vision_support.hpp"

using namespace rost;
using namespace rost::vision;
using rost::testing::TempDir;

namespace {

cv::Mat patterned(int w, int h, int seed) {
    cv::Mat m(h, w, CV_8UC3);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            m.at<cv::Vec3b>(y, x) = {static_cast<uint8_t>((x + seed * 40) & 255), static_cast<uint8_t>(y & 255),
                                     static_cast<uint8_t>((x * y + seed) & 255)};
    return m;
}

std::vector<Frame> readAll(FrameSource& s) {
    std::vector<Frame> out;
    Frame f;
    while (s.read(f) == ReadStatus::Ok) {
        out.push_back(f);
        out.back().image = f.image.clone();
    }
    return out;
}

std::string openError(const std::string& input) {
    Status st;
    auto s = openFrameSource(input, {}, st);
    EXPECT_FALSE(s) << input;
    EXPECT_FALSE(st.ok());
    EXPECT_EQ(st.message().find('\n'), std::string::npos) << "one line: " << st.message();
    return st.message();
}

// An MJPG clip of `frames` 64 x 48 patterned frames (patterned(64, 48, i)) at 12 fps.
bool writeClip(const std::string& path, int frames) {
    cv::VideoWriter w(path, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 12.0, cv::Size(64, 48));
    if (!w.isOpened()) return false;
    for (int i = 0; i < frames; ++i) w.write(patterned(64, 48, i));
    w.release();
    return true;
}

} // namespace

TEST(VisionSources, ImageDirectoryIsReadInNameOrderAtTheFirstImagesSize) {
    TempDir t;
    ASSERT_TRUE(cv::imwrite(t / "img_002.png", patterned(40, 30, 2)));
    ASSERT_TRUE(cv::imwrite(t / "img_001.png", patterned(40, 30, 1)));
    ASSERT_TRUE(cv::imwrite(t / "img_003.png", patterned(80, 60, 3)));  // another size: resized
    cv::Mat grey;
    cv::cvtColor(patterned(40, 30, 4), grey, cv::COLOR_BGR2GRAY);
    ASSERT_TRUE(cv::imwrite(t / "img_004.pgm", grey));                  // grey: becomes 3 channels
    rost::testing::writeText(t / "notes.txt", "not an image");
    Status st;
    auto src = openFrameSource(t.path(), {}, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().width, 40);
    EXPECT_EQ(src->info().height, 30);
    EXPECT_EQ(src->info().frames, 4);
    const auto frames = readAll(*src);
    ASSERT_EQ(frames.size(), 4u);
    for (std::size_t i = 0; i < frames.size(); ++i) {
        EXPECT_EQ(frames[i].index, static_cast<int64_t>(i));
        EXPECT_EQ(frames[i].image.size(), cv::Size(40, 30));
        EXPECT_EQ(frames[i].image.type(), CV_8UC3);
    }
    EXPECT_EQ(cv::norm(frames[0].image, patterned(40, 30, 1), cv::NORM_INF), 0.0) << "img_001 first";
    EXPECT_EQ(cv::norm(frames[1].image, patterned(40, 30, 2), cv::NORM_INF), 0.0);
    // The image of another size is scaled, and said so, naming it.
    const std::vector<std::string> notes = src->takeNotes();
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_EQ(notes[0], (t / "img_003.png") + ": 80x60, not the first image's 40x30: scaled to the 40x30 frame");
}

TEST(VisionSources, GlobSelectsMatchingFilesAndOptionsResize) {
    TempDir t;
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(cv::imwrite(t / ("a" + std::to_string(i) + ".png"), patterned(80, 60, i)));
    ASSERT_TRUE(cv::imwrite(t / "b0.png", patterned(80, 60, 9)));
    SourceOptions o;
    o.width = 40;  // height follows the aspect ratio
    Status st;
    auto src = openFrameSource(t / "a*.png", o, st);
    ASSERT_TRUE(src) << st.message();
    const auto frames = readAll(*src);
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_EQ(frames[0].image.size(), cv::Size(40, 30));
    // A height alone keeps the aspect ratio too; both sides are taken as given.
    for (const auto& [width, height, expect] : {std::tuple{0, 30, cv::Size(40, 30)}, std::tuple{0, 120, cv::Size(160, 120)},
                                                std::tuple{25, 25, cv::Size(25, 25)}}) {
        SourceOptions sized;
        sized.width = width;
        sized.height = height;
        auto s = openFrameSource(t / "a*.png", sized, st);
        ASSERT_TRUE(s) << st.message();
        EXPECT_EQ(cv::Size(s->info().width, s->info().height), expect) << width << "x" << height;
        const auto all = readAll(*s);
        ASSERT_EQ(all.size(), 3u);
        EXPECT_EQ(all[2].image.size(), expect) << width << "x" << height;
    }
    // A size words cannot be extracted from is refused, naming what was asked
    // (it gave frames of no words, and a run of empty outputs).
    SourceOptions tiny;
    tiny.width = 8;
    EXPECT_FALSE(openFrameSource(t / "a*.png", tiny, st));
    EXPECT_NE(st.message().find("a*.png: width 8, height 0 asked for: a 8x6 frame is too small to extract words"),
              std::string::npos)
        << st.message();
}

// A file or directory whose own name holds glob characters ("dive [x3f]",
// as downloaders name files) is itself, not a pattern; a pattern that matches
// nothing is still named.
TEST(VisionSources, ANameWithBracketsIsItsFileNotAPattern) {
    TempDir t;
    const std::string dir = t / "frames [1]";
    ASSERT_TRUE(std::filesystem::create_directory(dir));
    for (int i = 0; i < 2; ++i)
        ASSERT_TRUE(cv::imwrite(dir + "/f" + std::to_string(i) + ".png", patterned(40, 30, i)));
    const std::string image = t / "still [x3f].png";
    ASSERT_TRUE(cv::imwrite(image, patterned(40, 30, 5)));
    EXPECT_FALSE(isGlobInput(dir));
    EXPECT_FALSE(isGlobInput(image));
    EXPECT_TRUE(isGlobInput(t / "f[01].png"));
    Status st;
    auto d = openFrameSource(dir, {}, st);
    ASSERT_TRUE(d) << st.message();
    EXPECT_EQ(readAll(*d).size(), 2u);
    auto one = openFrameSource(image, {}, st);
    ASSERT_TRUE(one) << st.message();
    EXPECT_EQ(readAll(*one).size(), 1u);
    EXPECT_FALSE(openFrameSource(t / "none [2].png", {}, st));
    EXPECT_NE(st.message().find("none [2].png: no files match"), std::string::npos) << st.message();
}

// A link that leads to itself among the frames is no frame: skipped in a
// directory and a glob, never an exception (std::filesystem's throwing forms
// ended the tool with terminate()); as an input it is the system's error.
TEST(VisionSources, ALoopOfLinksAmongTheFramesIsSkippedNeverThrown) {
    TempDir t;
    std::filesystem::create_directory(t / "d");
    ASSERT_TRUE(cv::imwrite(t / "d/a.png", patterned(40, 30, 1)));
    ASSERT_EQ(::symlink((t / "d/loop.png").c_str(), (t / "d/loop.png").c_str()), 0);
    for (const std::string& input : {t / "d", t / "d/*.png"}) {
        Status st;
        auto src = openFrameSource(input, {}, st);
        ASSERT_TRUE(src) << input << ": " << st.message();
        EXPECT_EQ(readAll(*src).size(), 1u) << input;
    }
    const std::string loop = t / "d/loop.png";
    EXPECT_EQ(openError(loop), loop + ": cannot open: Too many levels of symbolic links");
    Status st;
    EXPECT_FALSE(openFrameSource(loop, {}, st));
    EXPECT_EQ(st.kind(), StatusKind::OsError);
}

TEST(VisionSources, VideoFileGivesItsFramesSizeAndRate) {
    TempDir t;
    ASSERT_TRUE(writeClip(t / "clip.avi", 9));
    Status st;
    auto src = openFrameSource(t / "clip.avi", {}, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().width, 64);
    EXPECT_EQ(src->info().height, 48);
    EXPECT_NEAR(src->info().fps, 12.0, 1e-6);
    const auto frames = readAll(*src);
    ASSERT_EQ(frames.size(), 9u);
    EXPECT_EQ(frames[3].timestamp_us, 250000);  // 3 / 12 fps
    // MJPG is lossy: frame 4 must be nearer its own image than its neighbours'.
    const double own = cv::norm(frames[4].image, patterned(64, 48, 4), cv::NORM_L1);
    EXPECT_LT(own, cv::norm(frames[4].image, patterned(64, 48, 3), cv::NORM_L1));
    EXPECT_LT(own, cv::norm(frames[4].image, patterned(64, 48, 5), cv::NORM_L1));
}

// A video cut short (a copy stopped half way, a card pulled while recording):
// its container still gives every frame, the decoder runs out early. That is
// an error naming the file and how many frames were decoded, not an end that
// would pass half a mission off as all of it; the whole file ends cleanly.
TEST(VisionSources, AVideoCutShortIsAnErrorNamingTheFramesDecoded) {
    TempDir t;
    ASSERT_TRUE(writeClip(t / "clip.avi", 120));
    const std::string whole = rost::testing::readText(t / "clip.avi");
    rost::testing::writeText(t / "cut.avi", whole.substr(0, whole.size() / 2));
    for (const char* name : {"clip.avi", "cut.avi"}) {
        SCOPED_TRACE(name);
        Status st;
        auto src = openFrameSource(t / name, {}, st);
        ASSERT_TRUE(src) << st.message();
        ASSERT_EQ(src->info().frames, 120);
        Frame f;
        int64_t decoded = 0;
        ReadStatus rs;
        while ((rs = src->read(f)) == ReadStatus::Ok) ++decoded;
        if (std::string(name) == "clip.avi") {
            EXPECT_EQ(rs, ReadStatus::End) << src->error();
            EXPECT_EQ(decoded, 120);
            continue;
        }
        EXPECT_EQ(rs, ReadStatus::Error);
        EXPECT_GT(decoded, 10);
        EXPECT_LT(decoded, 110);
        EXPECT_EQ(src->error(), (t / "cut.avi") + ": only " + std::to_string(decoded) +
                                    " of the 120 frames its container gives could be decoded: truncated or damaged "
                                    "(--max-frames " + std::to_string(decoded) + " models those)");
    }
}

// A variable-frame-rate video keeps its frames' own times (the decoder's
// presentation times), not index / nominal rate: here the rate drops from
// 10 to 2 frames a second after 1 s. The last frames, which the decoder
// holds back to the end of the stream, are timed by the step before them.
TEST(VisionSources, AVariableFrameRateVideoKeepsItsFramesTimes) {
    TempDir t;
    if (!rost::testing::writeVariableRateClip(t / "vfr.mp4")) GTEST_SKIP() << "no ffmpeg to encode a variable-rate clip with";
    Status st;
    auto src = openFrameSource(t / "vfr.mp4", {}, st);
    ASSERT_TRUE(src) << st.message();
    std::vector<int64_t> times;
    for (const Frame& f : readAll(*src)) times.push_back(f.timestamp_us);
    EXPECT_EQ(times, rost::testing::kVariableRateClipUs);
}

// Two transport streams joined, the second's clock behind the first's (at
// 5 frames a second where the first has 10): the frame after the jump is
// timed one step after the last, and the frames after it keep their own
// 200 ms steps (not the first part's 100 ms, as when every later frame
// fell back to the last step), the frames the decoder holds back too.
TEST(VisionSources, AVideoWhoseClockGoesBackKeepsItsLaterFramesSteps) {
    if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) GTEST_SKIP() << "no ffmpeg to encode a clip with";
    TempDir t;
    const std::string clip = "ffmpeg -v error -f lavfi -i testsrc=size=160x120:rate=";
    const std::string make = clip + "10 -frames:v 10 -c:v libx264 -pix_fmt yuv420p -output_ts_offset 60 '" + (t / "hi.ts") +
                             "' && " + clip + "5 -frames:v 6 -c:v libx264 -pix_fmt yuv420p '" + (t / "lo.ts") + "' && cat '" +
                             (t / "hi.ts") + "' '" + (t / "lo.ts") + "' > '" + (t / "back.ts") + "'";
    if (std::system(make.c_str()) != 0) GTEST_SKIP() << "ffmpeg cannot encode H.264 here";
    Status st;
    auto src = openFrameSource(t / "back.ts", {}, st);
    ASSERT_TRUE(src) << st.message();
    std::vector<int64_t> times, expected;
    for (const Frame& f : readAll(*src)) times.push_back(f.timestamp_us);
    for (int64_t i = 0; i < 10; ++i) expected.push_back(100000 * i);
    for (int64_t i = 0; i < 6; ++i) expected.push_back(1000000 + 200000 * i);
    EXPECT_EQ(times, expected);
}

// A recording cut before its index (an MP4 or QuickTime file written
// without faststart keeps its index, the moov box, at the end) cannot be
// opened at all: the error says it is truncated, not only that OpenCV
// cannot open it.
TEST(VisionSources, AVideoCutBeforeItsIndexIsNamedTruncated) {
    if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) GTEST_SKIP() << "no ffmpeg to encode a clip with";
    TempDir t;
    const std::string make = "ffmpeg -v error -f lavfi -i testsrc=size=160x120:rate=25 -t 4 -c:v libx264 -pix_fmt yuv420p '" +
                             (t / "whole.mp4") + "'";
    if (std::system(make.c_str()) != 0) GTEST_SKIP() << "ffmpeg cannot encode H.264 here";
    const std::string whole = rost::testing::readText(t / "whole.mp4");
    ASSERT_EQ(whole.find("moov"), whole.rfind("moov"));
    ASSERT_GT(whole.find("moov"), whole.find("mdat")) << "the index must come last for this test";
    rost::testing::writeText(t / "cut.mp4", whole.substr(0, whole.size() / 2));
    EXPECT_EQ(openError(t / "cut.mp4"), (t / "cut.mp4") + ": cannot decode video: truncated or damaged (its container's "
                                                          "boxes run past the end of the file)");
}

// A whole file that counts more frames than it shows: a clip cut with
// `ffmpeg -ss 1.3 -c copy` keeps the samples before its start for its edit
// list (here 185 counted, 102 shown). It is read to its end with a note, not
// refused as truncated; the same file (its index first) cut short in its
// bytes still is.
TEST(VisionSources, AWholeVideoCountingFramesItDoesNotShowIsReadWithANote) {
    if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) GTEST_SKIP() << "no ffmpeg to cut a clip with";
    TempDir t;
    const std::string make = "ffmpeg -v error -f lavfi -i testsrc=size=160x120:rate=25 -t 10 -c:v libx264 -g 250 "
                             "-pix_fmt yuv420p '" + (t / "long.mp4") + "' && ffmpeg -v error -ss 3.3 -i '" +
                             (t / "long.mp4") + "' -c copy -t 4 -movflags +faststart '" + (t / "cut.mp4") + "'";
    if (std::system(make.c_str()) != 0) GTEST_SKIP() << "ffmpeg cannot encode H.264 here";
    const std::string whole = rost::testing::readText(t / "cut.mp4");
    rost::testing::writeText(t / "short.mp4", whole.substr(0, whole.size() * 3 / 4));
    for (const char* name : {"cut.mp4", "short.mp4"}) {
        SCOPED_TRACE(name);
        Status st;
        auto src = openFrameSource(t / name, {}, st);
        ASSERT_TRUE(src) << st.message();
        const int64_t counted = src->info().frames;
        Frame f;
        int64_t decoded = 0;
        ReadStatus rs;
        while ((rs = src->read(f)) == ReadStatus::Ok) ++decoded;
        ASSERT_GT(counted, decoded + 10) << "the clip must count frames it does not show";
        const std::vector<std::string> notes = src->takeNotes();
        if (std::string(name) == "cut.mp4") {
            EXPECT_EQ(rs, ReadStatus::End) << src->error();
            ASSERT_EQ(notes.size(), 1u);
            EXPECT_EQ(notes[0], (t / name) + ": " + std::to_string(decoded) + " of the " + std::to_string(counted) +
                                    " frames its container counts were decoded; the file is whole (an edit list, or "
                                    "frames the recorder dropped, are counted and not shown)");
            continue;
        }
        EXPECT_EQ(rs, ReadStatus::Error);
        EXPECT_NE(src->error().find("truncated or damaged"), std::string::npos) << src->error();
    }
}

namespace {

// A QuickTime box: a 32-bit big-endian size (header included), then its type.
std::string box(const char* type, uint32_t body) {
    const uint32_t n = body + 8;
    std::string b{char(n >> 24), char(n >> 16), char(n >> 8), char(n)};
    return b + type + std::string(body, 'x');
}
// A box with a 64-bit size (size field 1), which may claim any length.
std::string largeBox(const char* type, uint64_t claimed) {
    std::string b{'\0', '\0', '\0', '\1'};
    b += type;
    for (int i = 7; i >= 0; --i) b += char(claimed >> (8 * i));
    return b;
}
// A RIFF chunk: the tag, a little-endian size (header excluded), the body, a
// pad byte when the size is odd (unless `pad` is false).
std::string chunk(const char* tag, uint32_t body, bool pad = true) {
    std::string b = tag;
    b += {char(body), char(body >> 8), char(body >> 16), char(body >> 24)};
    return b + std::string(body, 'y') + (pad && (body & 1) ? std::string(1, '\0') : std::string());
}

bool wholeBytes(const TempDir& t, const std::string& bytes, int max_chunks = kMaxContainerChunks) {
    rost::testing::writeText(t / "v", bytes);
    return containerIsWhole(t / "v", max_chunks);
}

} // namespace

// The walk that tells a whole video (counting frames it does not show) from
// a cut one, on hand-made bytes: every edge the review of the walk named.
TEST(VisionContainer, AFileIsWholeWhenEveryTopLevelBoxOrChunkEndsWithinIt) {
    TempDir t;
    const std::string mp4 = box("ftyp", 12) + box("moov", 40) + box("mdat", 100);
    EXPECT_TRUE(wholeBytes(t, mp4));
    EXPECT_FALSE(wholeBytes(t, mp4.substr(0, mp4.size() - 1))) << "a QuickTime box one byte short is cut";
    EXPECT_FALSE(wholeBytes(t, mp4.substr(0, mp4.size() - 50)));
    EXPECT_TRUE(wholeBytes(t, box("ftyp", 12) + std::string("\0\0\0\0\0\0\0\0mdat", 12)))
        << "size 0: the last box runs to the end";
    // Fewer than 8 bytes after the last box cannot start another: zeros
    // there are padding; a header cut short is a cut.
    EXPECT_TRUE(wholeBytes(t, mp4 + std::string(5, '\0')));
    EXPECT_FALSE(wholeBytes(t, mp4 + std::string("\0\0\1\0md", 6)));
    // A 64-bit size past the end, however large, is a cut: never a wrap of
    // the walk back into the file, nor past its end.
    for (const uint64_t claimed : {uint64_t{1} << 63, ~uint64_t{0} - 7, ~uint64_t{0} - 151, uint64_t{200}}) {
        SCOPED_TRACE(claimed);
        EXPECT_FALSE(wholeBytes(t, box("ftyp", 12) + largeBox("mdat", claimed) + std::string(100, 'z')));
    }
    EXPECT_TRUE(wholeBytes(t, box("ftyp", 12) + largeBox("mdat", 116) + std::string(100, 'z')));
    EXPECT_FALSE(wholeBytes(t, box("ftyp", 12) + largeBox("mdat", 8))) << "a 64-bit size under its own header";

    // An AVI: an odd-sized last chunk may lack its pad byte, and nothing more.
    const std::string avi = chunk("RIFF", 101);
    EXPECT_TRUE(wholeBytes(t, avi));
    EXPECT_TRUE(wholeBytes(t, chunk("RIFF", 101, false))) << "the pad byte of the last chunk missing";
    EXPECT_FALSE(wholeBytes(t, avi.substr(0, avi.size() - 2)));
    EXPECT_TRUE(wholeBytes(t, chunk("RIFF", 100) + chunk("AVIX", 51)));
    EXPECT_FALSE(wholeBytes(t, chunk("RIFF", 100) + chunk("AVIX", 51).substr(0, 40)));
}

// A walk that gives up proves nothing: a file of more top-level boxes than
// the walk reads is not taken as whole.
TEST(VisionContainer, AWalkThatStopsAtItsChunkLimitDoesNotCallTheFileWhole) {
    TempDir t;
    std::string many;
    for (int i = 0; i < 1000; ++i) many += box("free", 0);
    EXPECT_FALSE(wholeBytes(t, many, 999));
    EXPECT_TRUE(wholeBytes(t, many, 1000)) << "at the limit, the same boxes are walked to the end";
    EXPECT_TRUE(wholeBytes(t, many));
}

// A container without a frame count (Matroska, an MPEG stream): FFmpeg's
// estimate from the duration is no count. The length is unknown, as a
// camera's; the video is read to its end; where decoding falls short of the
// estimate a note says so (an intact file whose audio outlasts its video
// would fail otherwise, its work lost). A real 79-frame MPEG stream whose
// estimate is 1 frame plays whole.
TEST(VisionSources, AVideoWithoutAFrameCountIsReadToItsEndAndAShortfallNoted) {
    TempDir t;
    ASSERT_TRUE(writeClip(t / "clip.mkv", 120));
    const std::string whole = rost::testing::readText(t / "clip.mkv");
    rost::testing::writeText(t / "cut.mkv", whole.substr(0, whole.size() / 2));
    for (const char* name : {"clip.mkv", "cut.mkv"}) {
        SCOPED_TRACE(name);
        Status st;
        auto src = openFrameSource(t / name, {}, st);
        ASSERT_TRUE(src) << st.message();
        EXPECT_EQ(src->info().frames, -1);
        Frame f;
        int64_t decoded = 0;
        ReadStatus rs;
        while ((rs = src->read(f)) == ReadStatus::Ok) ++decoded;
        EXPECT_EQ(rs, ReadStatus::End) << src->error();
        const std::vector<std::string> notes = src->takeNotes();
        if (std::string(name) == "clip.mkv") {
            EXPECT_EQ(decoded, 120);
            EXPECT_TRUE(notes.empty());
            continue;
        }
        EXPECT_GT(decoded, 10);
        EXPECT_LT(decoded, 110);
        ASSERT_EQ(notes.size(), 1u);
        EXPECT_EQ(notes[0], (t / "cut.mkv") + ": " + std::to_string(decoded) +
                                " frames decoded where its duration suggested 120: the video may be cut short or "
                                "damaged (its container gives no frame count)");
    }
    ROST_FOOTAGE_OR_SKIP(cube, "visp-images-data", "usr/share/visp-images-data/ViSP-images/video/cube.mpeg");
    Status st;
    auto src = openFrameSource(cube, {}, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().frames, -1) << "not FFmpeg's estimate of 1";
    EXPECT_EQ(readAll(*src).size(), 79u);
    EXPECT_TRUE(src->takeNotes().empty());
}

TEST(VisionSources, JoinedInputsPlayInOrderAtTheFirstSize) {
    TempDir a, b;
    for (int i = 0; i < 2; ++i) ASSERT_TRUE(cv::imwrite(a / ("f" + std::to_string(i) + ".png"), patterned(40, 30, i)));
    for (int i = 0; i < 3; ++i) ASSERT_TRUE(cv::imwrite(b / ("g" + std::to_string(i) + ".png"), patterned(100, 100, i)));
    Status st;
    auto src = openFrameSources({a.path(), b.path()}, {}, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().frames, 5);
    const auto frames = readAll(*src);
    ASSERT_EQ(frames.size(), 5u);
    for (std::size_t i = 0; i < 5; ++i) {
        EXPECT_EQ(frames[i].index, static_cast<int64_t>(i));
        EXPECT_EQ(frames[i].image.size(), cv::Size(40, 30));
    }
    // Images have no time: 10 a second, the next input's first a step after the last.
    for (std::size_t i = 0; i < 5; ++i)
        EXPECT_EQ(frames[i].timestamp_us, static_cast<int64_t>(i) * kImagePeriodUs) << "frame " << i;
}

// A one-frame video joined before images: the images start one frame
// period of the video (25 fps: 40 ms) after it, not the images' 100 ms.
TEST(VisionSources, AJoinedOneFrameVideoLeavesItsOwnPeriodBeforeTheNext) {
    if (std::system("command -v ffmpeg > /dev/null 2>&1") != 0) GTEST_SKIP() << "no ffmpeg to encode a clip with";
    TempDir t, b;
    const std::string make = "ffmpeg -v error -f lavfi -i testsrc=size=40x30:rate=25 -frames:v 1 -c:v libx264 -pix_fmt yuv420p '" +
                             (t / "one.mp4") + "'";
    if (std::system(make.c_str()) != 0) GTEST_SKIP() << "ffmpeg cannot encode H.264 here";
    for (int i = 0; i < 2; ++i) ASSERT_TRUE(cv::imwrite(b / ("g" + std::to_string(i) + ".png"), patterned(40, 30, i)));
    Status st;
    auto src = openFrameSources({t / "one.mp4", b.path()}, {}, st);
    ASSERT_TRUE(src) << st.message();
    std::vector<int64_t> times;
    for (const Frame& f : readAll(*src)) times.push_back(f.timestamp_us);
    EXPECT_EQ(times, (std::vector<int64_t>{0, 40000, 40000 + kImagePeriodUs}));
}

// A frame shrunk on one side and stretched on the other is area-averaged
// (OpenCV's INTER_AREA): 96 x 16 columns alternating black and white, read
// at 32 x 32, are greys of 1/3 and 2/3, not every third column sampled
// (pure black or white, as a linear resize gives).
TEST(VisionSources, AFrameShrunkOnOneSideIsAveragedThere) {
    TempDir t;
    cv::Mat img(16, 96, CV_8UC3, cv::Scalar::all(0));
    for (int x = 1; x < 96; x += 2) img.col(x).setTo(cv::Scalar::all(255));
    ASSERT_TRUE(cv::imwrite(t / "stripes.png", img));
    SourceOptions o;
    o.width = o.height = 32;
    Status st;
    auto src = openFrameSource(t / "stripes.png", o, st);
    ASSERT_TRUE(src) << st.message();
    const auto frames = readAll(*src);
    ASSERT_EQ(frames.size(), 1u);
    const cv::Mat& f = frames[0].image;
    ASSERT_EQ(f.size(), cv::Size(32, 32));
    for (int x = 0; x < 32; ++x) {
        const int v = f.at<cv::Vec3b>(16, x)[0];
        EXPECT_TRUE(std::abs(v - 85) <= 1 || std::abs(v - 170) <= 1) << "column " << x << ": " << v;
    }
}

// The clock behind a video's time stamps, case by case (rost/vision/presentation_clock.hpp).
TEST(PresentationClock, KeepsTheDecodersTimesAndStepsOverWhatItCannotUse) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto times = [](double fps, std::vector<double> ms) {
        PresentationClock c(fps);
        std::vector<int64_t> out;
        for (double m : ms) out.push_back(c.next(m));
        return out;
    };
    using V = std::vector<int64_t>;
    EXPECT_EQ(times(25, {0, 33.3, 70}), (V{0, 33300, 70000})) << "a variable rate's own times";
    EXPECT_EQ(times(25, {40, 80, 120, 0, 0}), (V{40000, 80000, 120000, 160000, 200000})) << "held-back frames' 0";
    EXPECT_EQ(times(10, {10000, 10100, 10200, 500, 700, 900}), (V{10000000, 10100000, 10200000, 10300000, 10500000, 10700000}))
        << "a clock that went back: one step, then the frames' own";
    EXPECT_EQ(times(25, {-50, -10, 30}), (V{0, 40000, 80000})) << "a negative start is 0";
    EXPECT_EQ(times(25, {0, nan, 1e10, 120}), (V{0, 40000, 80000, 120000})) << "no time, or one past 10^12 us";
    EXPECT_EQ(times(0, {0, nan}), (V{0, kImagePeriodUs})) << "an unknown rate";
    EXPECT_EQ(times(1e-9, {0, nan}), (V{0, kImagePeriodUs})) << "a rate below one frame in 10^6 s is unknown";
    EXPECT_EQ(times(25, {5000, 5000, 5040}), (V{5000000, 5040000, 5080000})) << "a repeated time";
}

TEST(VisionSources, UnreadableInputsGiveOneLineNamingTheInput) {
    TempDir t;
    EXPECT_NE(openError(t / "missing.mp4").find("missing.mp4: cannot open: No such file or directory"), std::string::npos);
    std::filesystem::create_directory(t / "empty");
    EXPECT_NE(openError(t / "empty").find("holds no images"), std::string::npos);
    rost::testing::writeText(t / "junk.mp4", std::string(4096, 'x'));
    EXPECT_NE(openError(t / "junk.mp4").find("junk.mp4: cannot decode video"), std::string::npos);
    rost::testing::writeText(t / "junk.png", "not a png");
    EXPECT_NE(openError(t / "junk.png").find("junk.png: cannot decode image"), std::string::npos);
    EXPECT_NE(openError(t / "*.nothing").find("no files match"), std::string::npos);
    EXPECT_NE(openError("camera:x").find("camera:N"), std::string::npos);
    // Numbers past an int, signs and spaces: refused, never wrapped to another camera's number.
    for (const char* bad : {"camera:4294967296", "camera:2147483648", "camera:-1", "camera:+1", "camera: 1"})
        EXPECT_EQ(openError(bad), std::string(bad) + ": expected camera:N with N a camera number from 0") << bad;
}

TEST(VisionSources, CameraIndexBeyondTheCamerasSaysNoCameraFoundAndWhatItSees) {
    const auto cams = listCameras();
    const std::string input = "camera:" + std::to_string(cams.size() + 3);
    const std::string m = openError(input);
    EXPECT_NE(m.find(input + ": no camera found"), std::string::npos) << m;
    if (haveLibcamera()) {
        EXPECT_NE(m.find("libcamera sees"), std::string::npos) << m;
    }
}

// ---- the frame size rule (rost/vision/frame_source.hpp) -------------------------

TEST(VisionFrameSize, FramesUnderSixteenPixelsASideAreTooSmallNamingTheSize) {
    for (auto [w, h] : {std::pair{0, 0}, {1, 1}, {1, 300}, {300, 1}, {15, 480}, {640, 15}})
        EXPECT_EQ(frameTooSmall(w, h), "a " + std::to_string(w) + "x" + std::to_string(h) +
                                           " frame is too small to extract words from (each side at least 16 pixels)");
    EXPECT_EQ(frameTooSmall(16, 16), "");
    EXPECT_EQ(frameTooSmall(640, 480), "");
}

TEST(VisionFrameSize, AModelIsSizedAtMost1920PixelsOnTheLongerSide) {
    const auto size = [](int w, int h) {
        const FrameSize s = modelFrameSize(w, h);
        return std::pair{s.width, s.height};
    };
    EXPECT_EQ(size(640, 480), std::pair(640, 480));
    EXPECT_EQ(size(1920, 1080), std::pair(1920, 1080));
    EXPECT_EQ(size(4000, 3000), std::pair(1920, 1440));
    EXPECT_EQ(size(3000, 4000), std::pair(1440, 1920));
    EXPECT_EQ(size(8000, 6000), std::pair(1920, 1440));
    EXPECT_EQ(size(65535, 16), std::pair(1920, 1));  // a strip keeps a row
}

// Images too small to extract words from are skipped with a note naming each
// file and its size, never fix the size, and leave no gap in the frame numbers.
TEST(VisionFrameSize, ImagesTooSmallAreSkippedAndNeverSizeTheSource) {
    TempDir t;
    ASSERT_TRUE(cv::imwrite(t / "a0.png", patterned(1, 1, 0)));
    ASSERT_TRUE(cv::imwrite(t / "a1.png", patterned(300, 1, 0)));
    ASSERT_TRUE(cv::imwrite(t / "a2.png", patterned(40, 30, 2)));
    ASSERT_TRUE(cv::imwrite(t / "a3.png", patterned(1, 300, 0)));
    ASSERT_TRUE(cv::imwrite(t / "a4.png", patterned(40, 30, 4)));
    Status st;
    auto src = openFrameSource(t.path(), {}, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().width, 40);
    EXPECT_EQ(src->info().height, 30);
    std::vector<std::string> notes = src->takeNotes();
    ASSERT_EQ(notes.size(), 2u);
    EXPECT_EQ(notes[0], (t / "a0.png") + ": a 1x1 frame is too small to extract words from (each side at least 16 pixels); skipped");
    EXPECT_NE(notes[1].find("a1.png: a 300x1 frame"), std::string::npos) << notes[1];
    EXPECT_TRUE(src->takeNotes().empty()) << "taken once";
    const std::vector<Frame> frames = readAll(*src);
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[0].index, 0);
    EXPECT_EQ(frames[1].index, 1);
    EXPECT_EQ(cv::norm(frames[1].image, patterned(40, 30, 4), cv::NORM_INF), 0.0) << "a3.png skipped, a4.png read";
    notes = src->takeNotes();
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_NE(notes[0].find("a3.png: a 1x300 frame"), std::string::npos) << notes[0];

    TempDir small;
    ASSERT_TRUE(cv::imwrite(small / "a.png", patterned(2, 2, 0)));
    ASSERT_TRUE(cv::imwrite(small / "b.png", patterned(8, 40, 0)));
    EXPECT_EQ(openError(small.path()), "images in " + small.path() +
                                           ": no image large enough to extract words from (each side at least 16 pixels)");
}

TEST(VisionFrameSize, AHugeFirstImageIsScaledWithANote) {
    TempDir t;
    ASSERT_TRUE(cv::imwrite(t / "a.png", patterned(4000, 3000, 1)));
    Status st;
    auto src = openFrameSource(t.path(), {}, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().width, 1920);
    EXPECT_EQ(src->info().height, 1440);
    const std::vector<std::string> notes = src->takeNotes();
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_EQ(notes[0], "frames of 4000x3000 are scaled to 1920x1440 (at most 1920 pixels on the longer side unless a "
                        "size is given)");
    // A size the caller gives is kept as given.
    SourceOptions o;
    o.width = 4000;
    src = openFrameSource(t.path(), o, st);
    ASSERT_TRUE(src) << st.message();
    EXPECT_EQ(src->info().width, 4000);
    EXPECT_TRUE(src->takeNotes().empty());
}

// What an input reads besides being its one file, so that a mission's
// checkpoint is never written among its frames: an image directory's image
// files (directly in it), a glob's files now and those its pattern would
// match once written, wildcards in the directory part included, as glob(3)
// reads them (no hidden file matched by a wildcard).
TEST(VisionSources, AnInputReadsItsDirectorysImagesAndItsGlobsFiles) {
    TempDir t;
    std::filesystem::create_directories(t / "frames/sub");
    std::filesystem::create_directories(t / "run1");
    ASSERT_TRUE(cv::imwrite(t / "frames/0001.png", patterned(20, 20, 1)));
    ASSERT_TRUE(cv::imwrite(t / "run1/f0.png", patterned(20, 20, 2)));
    const std::string frames = t / "frames";
    EXPECT_TRUE(inputWouldRead(frames, t / "frames/0002.png"));
    EXPECT_TRUE(inputWouldRead(frames, t / "frames/sub/../0003.JPG"));
    EXPECT_FALSE(inputWouldRead(frames, t / "frames/model.ckpt")) << "not an image: the directory's listing skips it";
    EXPECT_FALSE(inputWouldRead(frames, t / "frames/sub/x.png")) << "not directly in it";
    EXPECT_FALSE(inputWouldRead(frames, t / "frames.png"));
    const std::string glob = t / "frames/*.png";
    EXPECT_TRUE(inputWouldRead(glob, t / "frames/0001.png"));
    EXPECT_TRUE(inputWouldRead(glob, t / "frames/new.png"));
    EXPECT_FALSE(inputWouldRead(glob, t / "frames/.hidden.png"));
    EXPECT_FALSE(inputWouldRead(glob, t / "frames/m.ckpt"));
    const std::string inDirectory = t / "ru?1/f0.png";
    EXPECT_TRUE(inputWouldRead(inDirectory, t / "run1/f0.png"));
    EXPECT_TRUE(inputWouldRead(t / "run*/*.png", t / "run1/../run1/ck.png"));
    EXPECT_FALSE(inputWouldRead(t / "run*/*.png", t / "other/ck.png"));
    EXPECT_FALSE(inputWouldRead("camera:0", t / "frames/0002.png"));
    EXPECT_FALSE(inputWouldRead(t / "run1/f0.png", t / "run1/f1.png")) << "a file input is its one file";
}

namespace {
// Frames 0, 1, 2, ... up to `count`, live (a camera) or not (a file).
class CountingSource final : public FrameSource {
public:
    CountingSource(bool live, int64_t count) : count_(count) {
        info_.live = live;
        info_.width = info_.height = 32;
        info_.frames = live ? -1 : count;
    }
    ReadStatus read(Frame& out) override {
        if (next_ == count_) return ReadStatus::End;
        out.image = cv::Mat(32, 32, CV_8UC3, cv::Scalar(0, 0, 0));
        out.index = next_++;
        return ReadStatus::Ok;
    }

private:
    int64_t count_, next_ = 0;
};

std::vector<int64_t> missionFrames(FrameSource& s, int64_t skipThrough, int64_t before) {
    std::vector<int64_t> out;
    Frame f;
    while (readMissionFrame(s, skipThrough, before, f) == ReadStatus::Ok) out.push_back(f.index);
    return out;
}
} // namespace

// Resuming a checkpoint whose last frame is 4: a file's frames 0..4 are
// skipped, a camera's first frame is numbered 5, right after it.
TEST(VisionSources, AResumedMissionSkipsAFilesFramesAndNumbersACamerasAfterTheCheckpoint) {
    CountingSource file(false, 8), camera(true, 3);
    EXPECT_EQ(missionFrames(file, 4, 5), (std::vector<int64_t>{5, 6, 7}));
    EXPECT_EQ(missionFrames(camera, 4, 5), (std::vector<int64_t>{5, 6, 7}));
    CountingSource fresh(true, 2);
    EXPECT_EQ(missionFrames(fresh, -1, 0), (std::vector<int64_t>{0, 1}));
}
