// rost.Config: every setting of the one schema (rost/settings_schema.hpp) as
// a keyword argument, the key with dots and dashes as underscores
// (cell_space=64); the names, types, ranges and defaults come from the schema.

#include <string>

#include "bindings.hpp"

namespace rost::python {

namespace {

std::string typeName(const py::handle& h) { return py::str(py::type::handle_of(h).attr("__name__")); }

// Python's bool or numpy's (numpy.bool_, numpy.True_).
bool isBool(const py::handle& v) {
    if (py::isinstance<py::bool_>(v)) return true;
    const py::handle type = py::type::handle_of(v);
    return py::str(type.attr("__module__")).cast<std::string>() == "numpy" &&
           typeName(v).rfind("bool", 0) == 0;
}

// The text form setSetting() parses. Python's own spellings: True/False for a
// Bool, repr() of a float (shortest round trip), an int's digits.
std::string valueText(const SettingSpec& spec, const std::string& name, const py::handle& v, const char* what) {
    if (isBool(v)) {
        if (spec.type != SettingType::Bool)
            throw py::value_error(std::string(what) + ": " + name + ": expected a number, found " + py::repr(v).cast<std::string>());
        return PyObject_IsTrue(v.ptr()) == 1 ? "true" : "false";
    }
    if (py::isinstance<py::str>(v)) return v.cast<std::string>();
    if (py::isinstance<py::float_>(v)) return py::repr(v).cast<std::string>();
    // numpy floating scalars (float32, float64) through Python's float: repr() of the nearest double.
    if (!py::hasattr(v, "__index__") && py::hasattr(v, "__float__"))
        return py::repr(py::float_(py::reinterpret_borrow<py::object>(v))).cast<std::string>();
    if (py::hasattr(v, "__index__")) return py::str(py::int_(py::reinterpret_borrow<py::object>(v))).cast<std::string>();  // int, numpy integers
    throw py::value_error(std::string(what) + ": " + name + ": expected a number, a bool or a string, found " + typeName(v));
}

} // namespace

void applySettings(Settings& s, const py::kwargs& kwargs, const char* what, bool wordsOnly) {
    std::string budgetKey;
    for (const auto& [k, v] : kwargs) {
        const std::string name = py::str(k);
        const SettingSpec* spec = findSetting(name);
        if (!spec) {
            std::string msg = std::string(what) + ": unknown setting '" + name + "'";
            if (const SettingSpec* near = closestSetting(name)) msg += " (did you mean '" + paramName(*near) + "'?)";
            throw py::value_error(msg);
        }
        if (wordsOnly && spec->group != SettingGroup::Words)
            throw py::value_error(std::string(what) + ": '" + name +
                                  "' is not a word setting (words_*, orb_*, thumb_cell; model settings go to rost.Config)");
        if (spec->isBudget()) {
            if (!budgetKey.empty())
                throw py::value_error(std::string(what) + ": '" + name + "' and '" + budgetKey +
                                      "' both set a budget (give one of budget_refines, budget_tokens, budget_ms)");
            budgetKey = name;
        }
        if (auto p = setSettingText(s, *spec, valueText(*spec, name, v, what)))
            throw py::value_error(std::string(what) + ": " + p->describe(paramName));
    }
    // Python names a setting by its keyword: eta, cell_space (never strategy.eta or cell.space).
    if (auto p = checkSettings(s)) throw py::value_error(std::string(what) + ": " + p->describe(paramName));
}

py::object settingObject(const Settings& s, const SettingSpec& spec) {
    const std::string text = settingValue(s, spec.key);
    if (text.empty()) return py::none();
    switch (spec.type) {
    case SettingType::Integer:
    case SettingType::BudgetSteps:
    case SettingType::BudgetTokens:
        return py::int_(py::str(text));  // seed may exceed int64
    case SettingType::Real:
    case SettingType::BudgetMs:
        return py::float_(py::str(text));  // Python parses subnormals (std::stod throws on them)
    case SettingType::Bool:
        return py::bool_(text == "true");
    case SettingType::Choice:
        break;
    }
    return py::str(text);
}

namespace {

py::dict toDict(const Settings& s) {
    py::dict d;
    for (const SettingSpec& spec : settingSpecs()) {
        py::object v = settingObject(s, spec);
        if (!v.is_none()) d[py::str(paramName(spec))] = v;
    }
    return d;
}

std::string repr(const Settings& s) {
    const Settings defaults;
    std::string out = "rost.Config(";
    bool first = true;
    for (const SettingSpec& spec : settingSpecs()) {
        const std::string v = settingValue(s, spec.key);
        if (v == settingValue(defaults, spec.key)) continue;
        out += first ? "" : ", ";
        out += paramName(spec);
        out += "=";
        out += py::repr(settingObject(s, spec)).cast<std::string>();
        first = false;
    }
    return out + ")";
}

const char* typeText(SettingType t) {
    switch (t) {
    case SettingType::Integer: return "int";
    case SettingType::Real: return "float";
    case SettingType::Bool: return "bool";
    case SettingType::Choice: return "str";
    case SettingType::BudgetSteps:
    case SettingType::BudgetTokens: return "int";
    case SettingType::BudgetMs: return "float";
    }
    return "?";
}

// Every setting: name, key, type, group, default, range, documentation.
py::list describe() {
    const Settings defaults;
    py::list out;
    for (const SettingSpec& spec : settingSpecs()) {
        py::dict d;
        d["name"] = paramName(spec);
        d["key"] = std::string(spec.key);
        d["type"] = typeText(spec.type);
        d["group"] = std::string(settingGroupNames(spec.group).name);
        d["default"] = settingObject(defaults, spec);
        d["range"] = settingRange(spec);
        d["doc"] = std::string(spec.doc);
        out.append(d);
    }
    return out;
}

} // namespace

// One read-only property a setting (dir() and tab completion list them), its
// documentation the schema's with the type, default and range.
void bindSettingProperties(py::class_<PyConfig>& c) {
    const Settings defaults;
    for (const SettingSpec& spec : settingSpecs()) {
        std::string doc = std::string(spec.doc) + " [" + typeText(spec.type) + ", default " +
                          py::repr(settingObject(defaults, spec)).cast<std::string>();
        if (const std::string range = settingRange(spec); !range.empty()) doc += ", " + range;
        doc += "]";
        const SettingSpec* p = &spec;
        c.def_property_readonly(paramName(spec).c_str(), [p](const PyConfig& cfg) { return settingObject(cfg.settings, *p); },
                                doc.c_str());
    }
}

void bindConfig(py::module_& m) {
    py::class_<PyConfig> cls(m, "Config", R"doc(Every setting of rost (the one settings schema), by keyword:
rost.Config(K=32, cell_space=64, sampler="uni+now", budget_refines=8).
Names are the configuration-file keys with dots and dashes as underscores;
an unknown name or a bad value raises ValueError naming it. rost.Config.describe()
lists every setting with its type, default, range and documentation; each setting is also a
read-only property (config.K, config.cell_space) documented by help(rost.Config).)doc");
    cls.def(py::init([](const py::kwargs& kw) {
                 PyConfig c;
                 applySettings(c.settings, kw, "rost.Config");
                 return c;
             }))
        .def("to_dict", [](const PyConfig& c) { return toDict(c.settings); },
             "Every setting by name (the budget key in force only); rost.Config(**d) gives the same Config.")
        .def("replace",
             [](const PyConfig& c, const py::kwargs& kw) {
                 PyConfig out = c;
                 applySettings(out.settings, kw, "rost.Config.replace");
                 return out;
             },
             "A copy with some settings changed.")
        .def_static("describe", &describe, "Every setting: name, key, type, group, default, range, doc.")
        .def("__getattr__",
             [](const PyConfig& c, const std::string& name) {
                 const SettingSpec* spec = findSetting(name);
                 if (!spec) throw py::attribute_error("rost.Config has no setting '" + name + "'");
                 return settingObject(c.settings, *spec);
             })
        .def("__eq__", [](const PyConfig& a, const PyConfig& b) { return toDict(a.settings).equal(toDict(b.settings)); })
        // Anything else: NotImplemented, so `config == None` is False and `config in [1, config]` works.
        .def("__eq__", [](const PyConfig&, const py::object&) { return py::reinterpret_borrow<py::object>(Py_NotImplemented); })
        .def("__repr__", [](const PyConfig& c) { return repr(c.settings); })
        .def(py::pickle([](const PyConfig& c) { return toDict(c.settings); },
                        [](const py::dict& d) {
                            PyConfig c;
                            applySettings(c.settings, py::kwargs(d), "rost.Config");
                            return c;
                        }))
        .def("__copy__", [](const PyConfig& c) { return c; })
        .def("__deepcopy__", [](const PyConfig& c, const py::object&) { return c; }, py::arg("memo"));
    bindSettingProperties(cls);
}

} // namespace rost::python
