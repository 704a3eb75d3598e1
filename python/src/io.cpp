// rost._rost.text: the core's text I/O layer (rost/text_io.hpp) for rost.io
// (python/rost/io.py). The reading, the splitting into lines and fields, the
// numbers and their errors ("PATH:LINE:COL: expected an integer, found 'x'"),
// the writers and the atomic write are the core's; rost.io keeps the
// formats' own checks and messages.

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "rost/text_io.hpp"

namespace rost::python {

namespace {

// The Python exception a file's failed read or write is: the library's kind
// (FileNotFoundError when the path, or, writing, its directory, is missing;
// PermissionError; IsADirectoryError), OSError otherwise; the message is the core's.
[[noreturn]] void raiseFileError(const Status& st) { raiseStatus(st, {}, PyExc_OSError); }

void checkContent(const Status& st) {
    if (!st.ok()) throw py::value_error(text::printable(st.message()));
}

// Lines that are blank (spaces and tabs) or start with '#' are skipped, as
// rost.io has always read the tool's files.
constexpr text::LineRules kRules{.skip_empty = true, .blank_is_empty = true, .skip_comments = true};

// A file's text read whole, and a reader of its lines after the ones taken.
class TextFile {
public:
    explicit TextFile(std::string path) : path_(std::move(path)) {
        if (Status st = text::readFile(path_, content_); !st.ok()) raiseFileError(st);
        lines_ = std::make_unique<text::LineReader>(text::withoutByteOrderMark(content_), path_, kRules);
    }

    // The next line's fields as strings; an empty list at the end.
    std::vector<std::string> header() {
        std::vector<std::string> out;
        text::Line line;
        if (!lines_->next(line)) return out;
        text::splitFields(line.text, ",", fields_);
        for (const text::Field& f : fields_) out.emplace_back(f.text);
        return out;
    }

    // The lines left, each a row of integers: (rows as int64 arrays, their line numbers).
    py::tuple integerRows() {
        py::list rows, numbers;
        text::Line line;
        std::vector<int64_t> values;
        while (lines_->next(line)) {
            text::splitFields(line.text, ",", fields_);
            values.resize(fields_.size());
            for (std::size_t i = 0; i < fields_.size(); ++i)
                checkContent(text::integerField(path_, line.number, fields_[i], "an integer", values[i]));
            py::array_t<int64_t> a(static_cast<py::ssize_t>(values.size()));
            std::copy(values.begin(), values.end(), a.mutable_data());
            rows.append(std::move(a));
            numbers.append(line.number);
        }
        return py::make_tuple(rows, numbers);
    }

    // The lines left, each an integer then numbers: (line numbers, first
    // column int64, the next width - 1 columns float64 (nan where a row is
    // short), each row's field count).
    py::tuple numberRows(std::size_t width) {
        std::vector<int64_t> numbers, first, counts;
        std::vector<double> values;
        const std::size_t rest = width > 0 ? width - 1 : 0;
        text::Line line;
        while (lines_->next(line)) {
            text::splitFields(line.text, ",", fields_);
            int64_t frame = 0;
            checkContent(text::integerField(path_, line.number, fields_[0], "an integer", frame));
            const std::size_t at = values.size();
            values.resize(at + rest, std::numeric_limits<double>::quiet_NaN());
            for (std::size_t i = 1; i < fields_.size(); ++i) {
                double v = 0;
                checkContent(text::doubleField(path_, line.number, fields_[i], "a number", v));
                if (i <= rest) values[at + i - 1] = v;
            }
            numbers.push_back(line.number);
            first.push_back(frame);
            counts.push_back(static_cast<int64_t>(fields_.size()));
        }
        const auto rows = static_cast<py::ssize_t>(first.size());
        py::array_t<double> table({rows, static_cast<py::ssize_t>(rest)});
        std::copy(values.begin(), values.end(), table.mutable_data());
        return py::make_tuple(py::array_t<int64_t>(rows, numbers.data()), py::array_t<int64_t>(rows, first.data()),
                              table, py::array_t<int64_t>(rows, counts.data()));
    }

private:
    std::string path_, content_;
    std::unique_ptr<text::LineReader> lines_;  // over content_
    std::vector<text::Field> fields_;
};

void writeText(const py::object& pathObject, const std::string& content) {
    const std::string path = pathArgument(pathObject, "path");
    if (Status st = text::writeFileAtomic(path, content); !st.ok()) raiseFileError(st);
}

using Int64s = py::array_t<int64_t, py::array::c_style | py::array::forcecast>;

// "timestamp,v1,v2,...\n" per row, written atomically.
void writeRows(const py::object& path, const Int64s& timestamps, const std::vector<Int64s>& rows) {
    if (static_cast<std::size_t>(timestamps.size()) != rows.size())
        throw py::value_error(std::to_string(timestamps.size()) + " timestamps for " + std::to_string(rows.size()) +
                              " rows");
    std::string out;
    for (std::size_t i = 0; i < rows.size(); ++i)
        text::appendRow(out, timestamps.at(static_cast<py::ssize_t>(i)),
                        std::span<const int64_t>(rows[i].data(), static_cast<std::size_t>(rows[i].size())));
    writeText(path, out);
}

// A 2-D integer array, a line per row, written atomically.
void writeMatrix(const py::object& path, const Int64s& m) {
    if (m.ndim() != 2) throw py::value_error("expected a 2-D array");
    std::string out;
    text::TableWriter table(out);
    const auto r = m.unchecked<2>();
    for (py::ssize_t i = 0; i < r.shape(0); ++i) {
        for (py::ssize_t j = 0; j < r.shape(1); ++j) table.cell(r(i, j));
        table.end();
    }
    writeText(path, out);
}

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

// A header, then a line a row: an integer first column, then number columns
// (`integer`: which of them are written as integers), as the rost tool
// writes perplexity.csv and surprise.csv; atomically.
void writeTable(const py::object& path, const std::vector<std::string>& header, const Int64s& first,
                const std::vector<Doubles>& columns, const std::vector<bool>& integer) {
    if (header.size() != columns.size() + 1) throw py::value_error("one header name a column, the first included");
    if (integer.size() != columns.size()) throw py::value_error("one integer flag a number column");
    const py::ssize_t n = first.size();
    for (const Doubles& c : columns)
        if (c.ndim() != 1 || c.size() != n)
            throw py::value_error("every column holds " + std::to_string(n) + " values, one a row");
    std::string out;
    text::TableWriter table(out);
    for (const std::string& h : header) table.cell(h);
    table.end();
    for (py::ssize_t i = 0; i < n; ++i) {
        table.cell(first.at(i));
        for (std::size_t j = 0; j < columns.size(); ++j) {
            const double v = columns[j].at(i);
            if (integer[j] && !(std::abs(v) < 9.2e18))  // a cast past int64 (or of a NaN) is undefined
                throw py::value_error(header[j + 1] + "[" + std::to_string(i) + "] = " + std::to_string(v) +
                                      " is not an integer in int64's range");
            if (integer[j]) table.cell(static_cast<int64_t>(v));
            else table.cell(v);
        }
        table.end();
    }
    writeText(path, out);
}

} // namespace

void bindText(py::module_& m) {
    py::class_<TextFile>(m, "TextFile",
                         "A text file read whole; its lines (blank and '#' lines skipped) taken in order. "
                         "Errors name PATH:LINE:COL.")
        .def(py::init([](const py::object& path) { return std::make_unique<TextFile>(pathArgument(path, "path")); }), py::arg("path"))
        .def("header", &TextFile::header, "The next line's fields (strings); [] at the end.")
        .def("integer_rows", &TextFile::integerRows,
             "The lines left as rows of integers: (list of int64 arrays, list of line numbers).")
        .def("number_rows", &TextFile::numberRows, py::arg("width"),
             "The lines left as an integer then numbers: (line numbers, first column int64, "
             "float64 (rows, width - 1) with nan where a row is short, field counts).");
    m.def("write_rows", &writeRows, py::arg("path"), py::arg("timestamps"), py::arg("rows"),
          "Writes 'timestamp,v1,v2,...' lines atomically (a temporary file renamed over PATH).");
    m.def("write_matrix", &writeMatrix, py::arg("path"), py::arg("matrix"),
          "Writes a 2-D integer array, a line per row, atomically.");
    m.def("write_table", &writeTable, py::arg("path"), py::arg("header"), py::arg("first"), py::arg("columns"),
          py::arg("integer"),
          "Writes a header and rows (an integer column, then number columns) as the rost tool's CSV tables, "
          "atomically.");
}

} // namespace rost::python
