#include "outputs.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include <opencv2/imgproc.hpp>

#include "rost/text_io.hpp"
#include "rost/word_stream.hpp"

namespace fs = std::filesystem;

namespace rost::tool {

// ---- output directory -----------------------------------------------------------

OutputDir::~OutputDir() {
    if (!committed_) abandon();
}

Status OutputDir::open(const std::string& dir) {
    if (dir.empty()) return Status::error("--out: no output directory given");
    std::error_code ec;
    if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) return Status::error(dir + ": exists and is not a directory");
    // The directories this creates (outermost first), removed again if the run writes nothing.
    for (fs::path p = fs::absolute(dir, ec); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
        created_.insert(created_.begin(), p.string());
        if (p == p.parent_path()) break;
    }
    fs::create_directories(dir, ec);
    if (ec) return Status::error(dir + ": cannot create the output directory: " + ec.message());
    if (::access(dir.c_str(), W_OK) != 0) return Status::error(dir + ": cannot write: " + std::strerror(errno));
    dir_ = dir;
    std::string tmpl = dir + "/.rost-partial-XXXXXX";
    std::vector<char> buf(tmpl.begin(), tmpl.end());
    buf.push_back('\0');
    if (!::mkdtemp(buf.data())) return Status::error(dir + ": cannot create a staging directory: " + std::strerror(errno));
    staging_ = buf.data();
    return {};
}

Status OutputDir::probe(std::initializer_list<std::string_view> names, const std::vector<std::string_view>& skip) {
    for (std::string_view name : names) {
        names_.emplace_back(name);
        if (std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
        writes_.emplace_back(name);
        const std::string path = final(std::string(name));
        std::error_code ec;
        if (fs::is_directory(path, ec)) return Status::error(path + ": is a directory, not a file that can be written");
    }
    return {};
}

Status OutputDir::write(const std::string& name, const std::string& content) {
    const std::string path = staged(name);
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    if (!f) return Status::error(path + ": cannot write: " + std::strerror(errno));
    f.write(content.data(), static_cast<std::streamsize>(content.size()));
    f.flush();
    if (!f) return Status::error(path + ": write failed: " + std::strerror(errno));
    track(name);
    return {};
}

Status OutputDir::commit() {
    for (const auto& name : files_) {
        std::error_code ec;
        fs::rename(staged(name), final(name), ec);
        if (ec) return Status::error(final(name) + ": cannot move into place: " + ec.message());
    }
    std::error_code ec;
    fs::remove_all(staging_, ec);
    committed_ = true;
    return {};
}

std::vector<std::string> OutputDir::paths() const {
    std::vector<std::string> out;
    for (const auto& name : writes_) out.push_back(final(name));
    return out;
}

std::string OutputDir::earlierFilesNote() const {
    std::string names;
    for (const auto& name : names_) {
        std::error_code ec;
        if (std::find(files_.begin(), files_.end(), name) != files_.end() || !fs::is_regular_file(final(name), ec))
            continue;
        names += names.empty() ? " " : ", ";
        names += name;
    }
    if (names.empty()) return {};
    return "rost: note: not written by this run, kept from before in " + text::printable(dir_) + ":" + names + "\n";
}

void OutputDir::abandon() noexcept {
    if (staging_.empty()) return;
    std::error_code ec;
    fs::remove_all(staging_, ec);
    staging_.clear();
    // Directories this run made and left empty (fs::remove keeps one that holds anything).
    for (auto it = created_.rbegin(); it != created_.rend(); ++it) fs::remove(*it, ec);
}

// ---- topic model -------------------------------------------------------------------


// ---- drawing -----------------------------------------------------------------------

cv::Scalar topicColour(int k) {
    // Tableau-like palette (BGR), then golden-angle hues for larger K.
    static const cv::Scalar kPalette[] = {
        {180, 119, 31}, {14, 127, 255}, {44, 160, 44},  {40, 39, 214},   {189, 103, 148}, {75, 86, 140},
        {194, 119, 227}, {127, 127, 127}, {34, 189, 188}, {207, 190, 23}, {232, 199, 174}, {120, 187, 255},
        {138, 223, 152}, {150, 152, 255}, {213, 176, 197}, {148, 156, 196}};
    constexpr int n = sizeof kPalette / sizeof kPalette[0];
    if (k < n) return kPalette[k];
    cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(static_cast<int>(k * 137.508) % 180, 200, 220)), bgr;
    cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
    const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
    return {static_cast<double>(c[0]), static_cast<double>(c[1]), static_cast<double>(c[2])};
}

std::pair<double, double> timeAxis(std::span<const FrameRow> rows) {
    if (rows.empty()) return {0.0, 1.0};
    const double f0 = static_cast<double>(rows.front().timestamp);
    // At least one unit wide, and wide enough for a double to tell its tenths
    // apart: at 1.7e18 (nanoseconds) f0 + 1 is f0, the axis would divide 0 by
    // 0 and its ticks would not advance.
    return {f0, std::max(f0 + std::max(1.0, std::abs(f0) * 1e-12), static_cast<double>(rows.back().timestamp))};
}

std::vector<std::size_t> surprisePeaks(std::span<const FrameRow> rows, std::size_t count, std::size_t separation) {
    // A peak is a frame whose surprise jumps above the recent past: score =
    // surprise / median of the 10 frames before it. The first frames, where an
    // empty model finds everything surprising, are not candidates.
    constexpr std::size_t kPast = 10;
    constexpr double kMinJump = 2.0;
    const std::size_t warm = std::min<std::size_t>(kPast, rows.size() / 10 + 3);
    std::vector<std::pair<double, std::size_t>> scored;
    std::vector<double> past;
    for (std::size_t i = warm; i < rows.size(); ++i) {
        if (!std::isfinite(rows[i].surprise)) continue;
        past.clear();
        for (std::size_t j = i >= kPast ? i - kPast : 0; j < i; ++j)
            if (std::isfinite(rows[j].surprise)) past.push_back(rows[j].surprise);
        if (past.empty()) continue;
        std::nth_element(past.begin(), past.begin() + past.size() / 2, past.end());
        const double med = past[past.size() / 2];
        const double score = med > 0 ? rows[i].surprise / med : 0.0;
        if (score >= kMinJump) scored.emplace_back(score, i);
    }
    std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<std::size_t> peaks;
    for (const auto& [score, i] : scored) {
        if (peaks.size() == count) break;
        bool near = false;
        for (std::size_t p : peaks)
            if ((i > p ? i - p : p - i) < separation) near = true;
        if (!near) peaks.push_back(i);
    }
    return peaks;
}

namespace {

const cv::Scalar kInk(40, 40, 40), kGrid(228, 228, 228), kAxis(150, 150, 150), kWhite(255, 255, 255);
const cv::Scalar kInstant(14, 127, 255), kFinal(180, 119, 31), kSurprise(40, 39, 214), kPeak(40, 39, 214);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

void text(cv::Mat& img, const std::string& s, cv::Point at, double scale, cv::Scalar colour, int thickness = 1) {
    cv::putText(img, s, at, kFont, scale, colour, thickness, cv::LINE_AA);
}
int textWidth(const std::string& s, double scale, int thickness = 1) {
    int base = 0;
    return cv::getTextSize(s, kFont, scale, thickness, &base).width;
}

double niceStep(double range, int target) {
    if (!(range > 0)) return 1.0;
    const double raw = range / target;
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (raw <= m * mag) return m * mag;
    return 10.0 * mag;
}

std::string tickLabel(double v, double step) {
    char buf[32];
    if (step >= 1.0 || v == 0.0) std::snprintf(buf, sizeof buf, "%.0f", v);
    else if (step >= 0.1) std::snprintf(buf, sizeof buf, "%.1f", v);
    else std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
}

constexpr int kMaxTicks = 64;  // niceStep aims at 2 to 10

// A label in %g's short form with the significant digits ticks `step` apart
// up to `mag` need to differ: 1.025e+10 at steps of 2.5e8, not "1.02e+10".
std::string shortLabel(double v, double step, double mag) {
    const double e = std::floor(std::log10(step));
    const double mantissa = step / std::pow(10.0, e);
    const int fraction = std::abs(mantissa - std::round(mantissa)) > 1e-6 ? 1 : 0;  // 2.5: one digit more
    const int digits = std::clamp(static_cast<int>(std::floor(std::log10(std::max(mag, step))) - e) + 1 + fraction, 1, 17);
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

} // namespace

int tickLabelWidth(const std::string& label) { return textWidth(label, 0.42); }

bool tickLabelsRead(const TimeTicks& t, double x0, double x1, int width) {
    for (const std::string& l : t.labels)
        if (l.size() - (!l.empty() && l.front() == '-' ? 1 : 0) > 9) return false;
    for (std::size_t i = 1; i < t.at.size(); ++i) {
        const double apart = (t.at[i] - t.at[i - 1]) / (x1 - x0) * (width - 1);
        if (apart < (tickLabelWidth(t.labels[i - 1]) + tickLabelWidth(t.labels[i])) / 2.0 + 12) return false;
    }
    return true;
}

TimeTicks timeTicks(double x0, double x1, int width) {
    TimeTicks t;
    if (!(x1 > x0) || width <= 0) return t;
    // From ten ticks down to two, the first whose labels have room.
    for (int target : {10, 8, 6, 4, 3, 2}) {
        const double step = std::max(1.0, niceStep(x1 - x0, target));
        const double first = std::ceil(x0 / step);
        // Counted, not stepped: near 1e18 a double cannot tell x + step from x.
        std::vector<double> at;
        for (int i = 0; i <= kMaxTicks; ++i) {
            const double x = (first + i) * step;
            if (!(x <= x1 + 1e-9)) break;
            at.push_back(x);
        }
        if (at.empty()) continue;
        // Labels of more than nine characters are written short ("-5e+12"),
        // and, on an axis far narrower than its stamps, read from the first tick.
        const double mag = std::max(std::abs(at.front()), std::abs(at.back()));
        const bool longLabels = tickLabel(mag, step).size() > 9;
        const double origin = longLabels && (x1 - x0) < mag / 100 ? at.front() : 0.0;
        std::vector<std::string> labels;
        for (double x : at) {
            if (origin == 0.0 && !longLabels) labels.push_back(tickLabel(x, step));
            else if (origin == 0.0) labels.push_back(shortLabel(x, step, mag));
            else if (x == origin) labels.emplace_back("+0");
            else if (step >= 1e5) labels.push_back("+" + shortLabel(x - origin, step, at.back() - origin));
            else labels.push_back("+" + tickLabel(x - origin, step));
        }
        t.at = std::move(at);
        t.labels = std::move(labels);
        t.origin = origin;
        if (tickLabelsRead(t, x0, x1, width)) break;  // else fewer ticks: fewer digits, more room
    }
    return t;
}

namespace {

struct Axes {
    cv::Rect box;
    double x0, x1, y0, y1;
    // A time outside [x0, x1] (a stream whose timestamps go back) at the box's edge, not past it.
    int px(double x) const {
        return box.x + static_cast<int>(std::lround(std::clamp((x - x0) / (x1 - x0), 0.0, 1.0) * (box.width - 1)));
    }
    int py(double y) const {
        return box.y + box.height - 1 - static_cast<int>(std::lround((y - y0) / (y1 - y0) * (box.height - 1)));
    }
};

void drawFrame(cv::Mat& img, const Axes& a, const std::string& ylabel, bool xLabels) {
    // Horizontal grid and y ticks.
    // Ticks counted, not stepped: at time stamps near 1e18 (nanoseconds) a
    // double cannot tell x + step from x, and a stepped loop never ends.
    const double ys = niceStep(a.y1 - a.y0, 4);
    const double yFirst = std::ceil(a.y0 / ys);
    for (int i = 0; i <= kMaxTicks; ++i) {
        const double y = (yFirst + i) * ys;
        if (!(y <= a.y1 + 1e-9)) break;
        const int p = a.py(y);
        cv::line(img, {a.box.x, p}, {a.box.x + a.box.width - 1, p}, kGrid, 1, cv::LINE_AA);
        const std::string s = tickLabel(y, ys);
        text(img, s, {a.box.x - 8 - textWidth(s, 0.42), p + 5}, 0.42, kInk);
    }
    // Vertical grid and x ticks.
    const TimeTicks xt = timeTicks(a.x0, a.x1, a.box.width);
    for (std::size_t i = 0; i < xt.at.size(); ++i) {
        const int p = a.px(xt.at[i]);
        cv::line(img, {p, a.box.y}, {p, a.box.y + a.box.height - 1}, kGrid, 1, cv::LINE_AA);
        if (xLabels)
            text(img, xt.labels[i], {p - tickLabelWidth(xt.labels[i]) / 2, a.box.y + a.box.height + 17}, 0.42, kInk);
    }
    if (xLabels && xt.origin != 0.0) {  // the origin the labels count from, above the box's right end
        char buf[64];
        std::snprintf(buf, sizeof buf, "time since %.0f", xt.origin);
        text(img, buf, {a.box.x + a.box.width - textWidth(buf, 0.42), a.box.y - 6}, 0.42, kInk);
    }
    cv::rectangle(img, a.box, kAxis, 1);
    // Rotated y label: draw into a small image and rotate.
    const int w = textWidth(ylabel, 0.5) + 4;
    cv::Mat lab(22, w, CV_8UC3, kWhite);
    text(lab, ylabel, {2, 16}, 0.5, kInk);
    cv::Mat rot;
    cv::rotate(lab, rot, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int x = 8, y = a.box.y + (a.box.height - rot.rows) / 2;
    if (y >= 0 && y + rot.rows <= img.rows) rot.copyTo(img(cv::Rect(x, y, rot.cols, rot.rows)));
}

void polyline(cv::Mat& img, const Axes& a, std::span<const FrameRow> rows, double FrameRow::*field, cv::Scalar c,
              int thickness) {
    std::vector<cv::Point> pts;
    auto flush = [&] {
        if (pts.size() > 1) cv::polylines(img, pts, false, c, thickness, cv::LINE_AA);
        else if (pts.size() == 1) cv::circle(img, pts[0], thickness, c, -1, cv::LINE_AA);
        pts.clear();
    };
    for (const auto& r : rows) {
        const double v = r.*field;
        if (!std::isfinite(v)) {
            flush();
            continue;
        }
        pts.emplace_back(a.px(static_cast<double>(r.timestamp)), a.py(std::clamp(v, a.y0, a.y1)));
    }
    flush();
}

void range(std::span<const FrameRow> rows, std::initializer_list<double FrameRow::*> fields, double& lo, double& hi,
           std::size_t skip = 0) {
    lo = std::numeric_limits<double>::infinity();
    hi = -lo;
    for (std::size_t i = rows.size() > skip ? skip : 0; i < rows.size(); ++i)
        for (auto f : fields) {
            const FrameRow& r = rows[i];
            const double v = r.*f;
            if (std::isfinite(v)) {
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
        }
    if (!std::isfinite(lo)) lo = 0, hi = 1;
    if (hi - lo < 1e-9) hi = lo + 1.0;
    const double pad = 0.06 * (hi - lo);
    lo = std::max(0.0, lo - pad);
    hi += pad;
}

void legend(cv::Mat& img, cv::Point at, std::initializer_list<std::pair<const char*, cv::Scalar>> items) {
    int x = at.x;
    for (const auto& [name, c] : items) {
        cv::line(img, {x, at.y - 5}, {x + 22, at.y - 5}, c, 3, cv::LINE_AA);
        text(img, name, {x + 28, at.y}, 0.45, kInk);
        x += 40 + textWidth(name, 0.45) + 18;
    }
}

// The surprise curve, filled, with the empty model's first value labelled when clipped.
void drawSurprise(cv::Mat& img, const Axes& sur, std::span<const FrameRow> rows, bool resumed, std::size_t warm, double lo,
                  double hi) {
    std::vector<cv::Point> poly;
    for (const auto& r : rows)
        if (std::isfinite(r.surprise))
            poly.emplace_back(sur.px(static_cast<double>(r.timestamp)), sur.py(std::clamp(r.surprise, lo, hi)));
    if (poly.size() > 1) {
        std::vector<cv::Point> fill = poly;
        fill.emplace_back(poly.back().x, sur.py(lo));
        fill.emplace_back(poly.front().x, sur.py(lo));
        // Blended in the plot's box (and two pixels around it for the
        // anti-aliased edge), not the whole image: every point lies in the box
        // (Axes clamps), a blend of a pixel with itself leaves it as it was,
        // so the bytes are the same, for a quarter of the work.
        const cv::Rect around = (sur.box + cv::Size(4, 4) - cv::Point(2, 2)) & cv::Rect(0, 0, img.cols, img.rows);
        for (cv::Point& p : fill) p -= around.tl();
        cv::Mat under = img(around);
        cv::Mat layer = under.clone();
        cv::fillPoly(layer, std::vector<std::vector<cv::Point>>{fill}, cv::Scalar(190, 190, 240), cv::LINE_AA);
        cv::addWeighted(layer, 0.55, under, 0.45, 0, under);
        drawFrame(img, sur, "surprise", true);
        cv::polylines(img, poly, false, kSurprise, 2, cv::LINE_AA);
    }
    if (!resumed && !rows.empty() && rows.size() > warm && rows.front().surprise > hi) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "first: %.0f (empty model)", rows.front().surprise);
        text(img, buf, {sur.box.x + 14, sur.box.y + 16}, 0.42, cv::Scalar(110, 110, 110));
    }
}

// Dashed lines through both plots at the surprise peaks, each labelled with its frame.
void drawPeaks(cv::Mat& img, const Axes& ppl, const Axes& sur, std::span<const FrameRow> rows,
               const std::vector<std::size_t>& peaks) {
    for (std::size_t p : peaks) {
        const int x = sur.px(static_cast<double>(rows[p].timestamp));
        for (int y = ppl.box.y; y < sur.box.y + sur.box.height; y += 8)
            cv::line(img, {x, y}, {x, std::min(y + 4, sur.box.y + sur.box.height - 1)}, kPeak, 1, cv::LINE_AA);
        char buf[64];
        std::snprintf(buf, sizeof buf, "frame %lld", static_cast<long long>(rows[p].timestamp));
        const int w = textWidth(buf, 0.45);
        const int tx = std::clamp(x - w / 2, sur.box.x + 2, sur.box.x + sur.box.width - w - 2);
        cv::rectangle(img, {tx - 3, sur.box.y + 4}, {tx + w + 3, sur.box.y + 22}, kWhite, -1);
        text(img, buf, {tx, sur.box.y + 18}, 0.45, kPeak);
    }
}

// Topic mix over time: a column per pixel, stacked topic shares.
void drawTopicMix(cv::Mat& img, const cv::Rect& box, std::span<const FrameRow> rows, double f0, double f1) {
    const int left = box.x, topY = box.y, topH = box.height;
    for (int x = 0; x < box.width; ++x) {
        const double f = f0 + (f1 - f0) * x / std::max(1, box.width - 1);
        auto it = std::lower_bound(rows.begin(), rows.end(), f,
                                   [](const FrameRow& r, double v) { return static_cast<double>(r.timestamp) < v; });
        if (it == rows.end()) it = rows.end() - (rows.empty() ? 0 : 1);
        if (it == rows.end() || it->topic_share.empty()) continue;
        double acc = 0.0;
        for (int k = 0; k < static_cast<int>(it->topic_share.size()); ++k) {
            const double s = it->topic_share[static_cast<std::size_t>(k)];
            if (s <= 0) continue;
            const int yA = box.y + static_cast<int>(std::lround(acc * box.height));
            acc += s;
            const int yB = box.y + static_cast<int>(std::lround(acc * box.height));
            if (yB > yA) cv::line(img, {box.x + x, yA}, {box.x + x, yB - 1}, topicColour(k), 1);
        }
    }
    cv::rectangle(img, box, kAxis, 1);
    text(img, "topics", {left - 8 - textWidth("topics", 0.42), topY + topH / 2 + 5}, 0.42, kInk);
}

// Thumbnails, each tied to its frame on the time axis.
struct Strip {
    int left, stripTop, topY, topH, n, tw, th;
};
void drawThumbs(cv::Mat& img, const SummaryInput& in, const Strip& st, const Axes& sur, std::span<const FrameRow> rows,
                const std::vector<std::size_t>& peaks) {
    const int left = st.left, stripTop = st.stripTop, topY = st.topY, topH = st.topH, nThumbs = st.n, tw = st.tw,
              th = st.th;
    const int y = stripTop + 36;
    std::vector<int64_t> peakFrames;
    for (std::size_t p : peaks) peakFrames.push_back(rows[p].timestamp);
    for (int i = 0; i < nThumbs; ++i) {
        const std::size_t idx = in.thumbs.size() == static_cast<std::size_t>(nThumbs)
                                    ? static_cast<std::size_t>(i)
                                    : static_cast<std::size_t>(std::lround(
                                          static_cast<double>(i) * (in.thumbs.size() - 1) / std::max(1, nThumbs - 1)));
        const int x = left + i * (tw + 8);
        cv::Mat t;
        cv::resize(in.thumbs[idx], t, cv::Size(tw, th), 0, 0, cv::INTER_AREA);
        t.copyTo(img(cv::Rect(x, y, tw, th)));
        const int64_t fr = in.thumb_frames[idx];
        const bool isPeak = std::find(peakFrames.begin(), peakFrames.end(), fr) != peakFrames.end();
        cv::rectangle(img, cv::Rect(x - 1, y - 1, tw + 2, th + 2), isPeak ? kPeak : kAxis, isPeak ? 3 : 1);
        const int fx = sur.px(static_cast<double>(fr));
        cv::line(img, {fx, topY + topH + 1}, {x + tw / 2, y - 3}, cv::Scalar(170, 170, 170), 1, cv::LINE_AA);
        cv::circle(img, {fx, topY + topH + 1}, 3, isPeak ? kPeak : kAxis, -1, cv::LINE_AA);
        char buf[32];
        std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(fr));
        text(img, buf, {x + tw / 2 - textWidth(buf, 0.45) / 2, y + th + 20}, 0.45, isPeak ? kPeak : kInk);
    }
    text(img, "frame", {left - 8 - textWidth("frame", 0.42), y + th + 20}, 0.42, kInk);
}

} // namespace

Picture makePicture(int rows, int cols) {
    Picture p;
    p.pixels.reset(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * 3);
    p.image = cv::Mat(rows, cols, CV_8UC3, p.pixels.data());
    return p;
}

Picture drawSummary(const SummaryInput& in) {
    const std::span<const FrameRow> rows = in.rows;
    const int W = 1600, left = 96, right = 36;
    const int plotW = W - left - right;
    const bool thumbs = !in.thumbs.empty();
    const int titleH = 78, pplH = 230, gap = 38, surH = 190, topH = 46;
    // Thumbnail strip: as many as fit side by side.
    int tw = 0, th = 0, nThumbs = 0;
    if (thumbs) {
        const cv::Size s = in.thumbs[0].size();
        nThumbs = std::min<int>(static_cast<int>(in.thumbs.size()), 10);
        tw = (plotW - (nThumbs - 1) * 8) / nThumbs;
        th = static_cast<int>(std::lround(static_cast<double>(tw) * s.height / std::max(1, s.width)));
    }
    const int stripTop = titleH + pplH + gap + surH + 22 + topH + 26;
    const int H = stripTop + (thumbs ? 36 + th + 34 : 20);
    Picture picture = makePicture(H, W);
    cv::Mat& img = picture.image;
    img.setTo(kWhite);

    std::string title = in.title;
    while (title.size() > 8 && textWidth(title, 0.8, 2) > plotW) title = title.substr(0, title.size() - 4) + "...";
    text(img, title, {left, 34}, 0.8, kInk, 2);
    text(img, in.subtitle, {left, 60}, 0.5, cv::Scalar(90, 90, 90));

    const auto [f0, f1] = timeAxis(rows);
    const std::vector<std::size_t> peaks = surprisePeaks(rows, 3, std::max<std::size_t>(5, rows.size() / 20));

    // Perplexity.
    double lo, hi;
    range(rows, {&FrameRow::instantaneous, &FrameRow::final}, lo, hi);
    Axes ppl{cv::Rect(left, titleH, plotW, pplH), f0, f1, lo, hi};
    drawFrame(img, ppl, "perplexity", false);
    polyline(img, ppl, rows, &FrameRow::instantaneous, kInstant, 2);
    polyline(img, ppl, rows, &FrameRow::final, kFinal, 2);
    legend(img, {left + 12, titleH + 22}, {{"instantaneous", kInstant}, {"final", kFinal}});

    // Surprise, filled, with its peaks marked. The first frames meet an
    // empty model (surprise near V); they are left out of the scale, clipped
    // and labelled, so the rest of the curve keeps its detail.
    const std::size_t warm = in.resumed ? 0 : std::min<std::size_t>(10, rows.size() / 10 + 3);
    range(rows, {&FrameRow::surprise}, lo, hi, warm);
    Axes sur{cv::Rect(left, titleH + pplH + gap, plotW, surH), f0, f1, lo, hi};
    drawFrame(img, sur, "surprise", true);
    drawSurprise(img, sur, rows, in.resumed, warm, lo, hi);
    drawPeaks(img, ppl, sur, rows, peaks);

    // Topic mix over time: a column per pixel, stacked topic shares.
    const int topY = titleH + pplH + gap + surH + 26;
    drawTopicMix(img, cv::Rect(left, topY, plotW, topH), rows, f0, f1);

    // Thumbnails, each tied to its frame on the time axis.
    if (thumbs) drawThumbs(img, in, Strip{left, stripTop, topY, topH, nThumbs, tw, th}, sur, rows, peaks);
    return picture;
}

} // namespace rost::tool
