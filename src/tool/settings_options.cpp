// The tool's settings options, made from the settings schema: one option per
// setting (rost/settings_schema.hpp), never written by hand.

#include <cstdio>
#include <cstring>
#include <cerrno>
#include <deque>
#include <string>

#include <CLI/CLI.hpp>

#include "cli_given.hpp"
#include "rost/settings.hpp"
#include "tool.hpp"

namespace rost::tool {

namespace {

std::string groupTitle(SettingGroup g) { return std::string(settingGroupNames(g).title); }

std::string typeName(const SettingSpec& s) {
    switch (s.type) {
    case SettingType::Integer: return "INT";
    case SettingType::Real: return "NUM";
    case SettingType::Bool: return "";
    case SettingType::Choice: {
        std::string c = "{" + std::string(s.choices) + "}";
        std::replace(c.begin(), c.end(), '|', ',');
        return c;
    }
    case SettingType::BudgetMs: return "MS";
    default: return "N";
    }
}

// The frame size is the input's: --width/--height resize it (run) or give it (refine).
bool isFrameSize(const SettingSpec& s) { return s.key == "frame.width" || s.key == "frame.height"; }

// Which settings a command takes as options: refine has no frames to extract
// words from and no realtime threads, but refines on `threads` threads.
bool isOption(const SettingSpec& s, SettingsOptions::Command cmd) {
    if (s.has(setting_flags::Library) || isFrameSize(s)) return false;
    return cmd != SettingsOptions::Command::Refine || s.key == "threads" ||
           (s.group != SettingGroup::Words && s.group != SettingGroup::Runtime);
}

} // namespace

struct SettingsOptions::Impl {
    struct Entry {
        const SettingSpec* spec;
        CLI::Option* option;
        std::string text;
        bool flag = false;
    };
    ModelOptions& m;
    std::deque<Entry> entries;  // stable addresses: CLI11 writes into text and flag
    CLI::App& app;

    Impl(CLI::App& a, ModelOptions& mo) : m(mo), app(a) {}

    bool onCommandLine(const SettingSpec& spec) const {
        for (const Entry& e : entries)
            if (e.spec == &spec) return e.option->count() > 0;
        return false;
    }
    bool budgetOnCommandLine() const {
        for (const Entry& e : entries)
            if (e.spec->isBudget() && e.option->count() > 0) return true;
        return false;
    }
    Status applyFile(Settings& s, RunOptions* run, RefineOptions* ref);
};

SettingsOptions::SettingsOptions(CLI::App& app, ModelOptions& m, Command cmd) : impl_(std::make_unique<Impl>(app, m)) {
    std::vector<CLI::Option*> budgets;
    for (const SettingSpec& spec : settingSpecs()) {
        if (!isOption(spec, cmd)) continue;
        Impl::Entry& e = impl_->entries.emplace_back(Impl::Entry{&spec, nullptr, {}, false});
        const std::string names = spec.cli.empty() ? "--" + std::string(spec.key) : std::string(spec.cli);
        std::string help(spec.doc);
        if (spec.type != SettingType::Bool && spec.type != SettingType::Choice) help += "; " + settingRange(spec);
        if (spec.type == SettingType::Bool) {
            e.flag = spec.def == "true";
            e.option = app.add_flag(names, e.flag, help + " (default " + std::string(spec.def) + ")");
        } else {
            e.option = app.add_option(names, e.text, help)->type_name(typeName(spec));
            // Derived: the input decides, or (Cores) the machine does.
            if (spec.has(setting_flags::Derived))
                e.option->default_str(spec.has(setting_flags::Cores) ? "the cores" : "from the input");
            else if (!spec.def.empty()) e.option->default_str(std::string(spec.def));
        }
        e.option->group(groupTitle(spec.group));
        if (spec.isBudget()) budgets.push_back(e.option);
    }
    for (CLI::Option* a : budgets)
        for (CLI::Option* b : budgets)
            if (a != b) a->excludes(b);
    app.add_option("--config", m.config,
                   "settings file: `key = value` lines with the keys of these options (`rost config` prints them "
                   "all); options given on the command line win")
        ->type_name("FILE")
        ->check(givenPath())
        ->group(groupTitle(SettingGroup::Mission));
    if (cmd == Command::Config) return;
    app.add_option("--in.topicmodel", m.in_topicmodel,
                   "start from a topic model: a topicmodel.csv of an earlier run (K rows of V counts)")
        ->type_name("FILE")
        ->check(givenPath())
        ->group(groupTitle(SettingGroup::Model));
    app.add_option("--checkpoint", m.checkpoint,
                   "save the engine's whole state to FILE every --checkpoint.every observations and at the end "
                   "(atomically: a crash leaves the previous checkpoint)")
        ->type_name("FILE")
        ->check(givenPath())
        ->group(groupTitle(SettingGroup::Mission));
    app.add_option("--resume", m.resume,
                   "carry on the mission FILE (a --checkpoint) holds: its model, window and random state; input "
                   "frames or observations it already has (time stamp up to its last) are skipped, a camera's "
                   "frames are numbered after them. Model options may be repeated but not changed")
        ->type_name("FILE")
        ->check(givenPath())
        ->group(groupTitle(SettingGroup::Mission));
}

SettingsOptions::~SettingsOptions() = default;

namespace {

// A path option's check: "" refused by name (cli::nonEmpty), and "-", which
// many tools read as standard input or output: the rost tool reads and
// writes named files only, so "-" would otherwise become a file or directory
// of that name.
CLI::Validator namedPath(const std::string& what, const std::string& entry) {
    const CLI::Validator given = cli::nonEmpty(what);
    const std::string dash = "'-' names no " + what +
                             ": the rost tool neither reads standard input nor writes standard output (./- for a " +
                             entry + " of that name)";
    return CLI::Validator(
               [given, dash](std::string& s) { return s == "-" ? dash : given(s); }, "")
        .name(kPathValidator);
}

} // namespace

const CLI::Validator& givenPath(PathKind kind) {
    static const CLI::Validator file = namedPath("file", "file"),
                                dir = namedPath("directory", "directory"), input = namedPath("input", "file");
    switch (kind) {
        case PathKind::Directory: return dir;
        case PathKind::Input: return input;
        case PathKind::File: break;
    }
    return file;
}

// --config FILE: its keys onto `s`, except where the command line gives the
// same setting (the command line wins).
Status SettingsOptions::Impl::applyFile(Settings& s, RunOptions* runOpts, RefineOptions* ref) {
    Settings file = s;
    std::vector<ConfigKeyLine> keys;
    if (Status st = readSettingsFile(m.config, file, &keys); !st.ok()) return st;
    for (const auto& [key, line] : keys) {
        const SettingSpec& spec = *findSetting(key);
        const std::string where = m.config + ":" + std::to_string(line) + ": key '" + key + "'";
        if (spec.has(setting_flags::Library))
            return Status::error(where + " is not a setting of this command (the rost tool sets it itself)");
        if (isFrameSize(spec)) {
            if (runOpts)
                return Status::error(where + " is not a setting of this command (the input sets the frame size; "
                                             "--width/--height resize it)");
            if (!ref) {  // rost config: printed set, as the file sets it (for rost refine)
                m.given.push_back(key);
                continue;
            }
            int& size = key == "frame.width" ? ref->width : ref->height;
            const CLI::Option* cli = app.get_option_no_throw(key == "frame.width" ? "--width" : "--height");
            if (!cli || cli->count() == 0) size = key == "frame.width" ? file.engine.model.frame_width : file.engine.model.frame_height;
            continue;
        }
        if (spec.isBudget() ? budgetOnCommandLine() : onCommandLine(spec)) continue;
        m.given.push_back(key);
        m.given_by_file.emplace_back(key, where + " = ");
    }
    s = file;
    return {};
}

Status SettingsOptions::apply(RunOptions* run, RefineOptions* ref) {
    Impl& d = *impl_;
    ModelOptions& m = d.m;
    Settings s = m.settings;
    if (!m.config.empty())
        if (Status st = d.applyFile(s, run, ref); !st.ok()) return Status::error("--config: " + st.message());
    for (const Impl::Entry& e : d.entries) {
        if (e.option->count() == 0) continue;
        const std::string value = e.spec->type == SettingType::Bool ? (e.flag ? "true" : "false") : e.text;
        if (auto p = setSettingText(s, *e.spec, value)) return Status::error(settingProblemText(m, *p));
        m.given.emplace_back(e.spec->key);
    }
    // `rost config` (no input): everything now. `run` and `refine`: ranges
    // now, the combinations once the mission knows the input's frame size,
    // length and words (planNew: a 3-line stream is not a 256-step ring).
    if (auto p = run || ref ? checkSettingRanges(s) : checkSettings(s)) return Status::error(settingProblemText(m, *p));
    m.settings = s;
    return {};
}

int configCommand(const ModelOptions& m) {
    const std::string text = formatSettingsDocumented(m.settings, m.given);
    const bool written = std::fwrite(text.data(), 1, text.size(), stdout) == text.size();
    if (!written || std::fflush(stdout) != 0 || std::ferror(stdout)) {
        const int err = errno;
        return fail(std::string("cannot write the settings to standard output: ") +
                    (err != 0 ? std::strerror(err) : "write error"));
    }
    return kExitOk;
}

} // namespace rost::tool
