// solid_input.h5's table and the one set of validated-read helpers of tq-solid's input reader
// (docs/formats.md "## solid_input.h5"). The table, input_schema.inc, is generated from
// scripts/tunnelquake/solver_input_schema.py; every group, attribute, default and bound the reader
// checks comes from it, and the reader names a row by its constant (input_schema::key::...).
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

#include "h5util.hpp"
#include "tq/core/types.hpp"

namespace tq::input_schema {

enum class Kind { Float, Int, Whole, Flag, Text, Names, Data };

/// One row of the table (an attribute, or a dataset: Kind::Data). `group` is a path whose `*` is a
/// free name (a region, a face group, a load); lists are comma-separated.
struct Attr {
  const char* group;
  const char* name;
  Kind kind;
  const char* unit;
  bool hasDefault;
  double def;           ///< numbers
  const char* defText;  ///< texts
  bool hasLo;
  double lo;
  bool loOpen;
  bool hasHi;
  double hi;
  bool hiOpen;
  bool required;
  const char* choices;
  const char* models;      ///< materials: the models that read it (empty: all)
  const char* requiredBy;  ///< materials: the models that need it
  const char* caseKey;     ///< the case key it is written from, for messages
};

/// A group and the members (subgroups, datasets) it may have; "*" = any name.
struct Group {
  const char* path;
  const char* members;
  bool required;
  const char* doc;
};

#include "input_schema.inc"

/// A row at run time: a compiled one, or a material row read from the file's /schema.
struct Row {
  std::string group, name;
  Kind kind = Kind::Float;
  std::string unit;
  bool hasDefault = false;
  double def = 0;
  std::string defText;
  bool hasLo = false, loOpen = false, hasHi = false, hiOpen = false, required = false;
  double lo = 0, hi = 0;
  std::vector<std::string> choices, models, requiredBy;
  std::string caseKey;
  Row() = default;
  Row(const Attr& a);  // NOLINT: a compiled row is a row
  bool readBy(const std::string& model) const;
  bool requiredFor(const std::string& model) const;
  /// Same declaration (all but the group and the case key).
  bool operator==(const Row& o) const;
};

/// The compiled rows of a group path (e.g. "/stages", kMaterials).
std::vector<Row> rowsOf(const std::string& group);
/// A material row from its text in /schema material_parameters (fields joined by '|').
Row parseMaterialRow(const std::string& text);

/// The validated reads of one input file: every failure is an InputError "solid input 'FILE',
/// WHERE: WHAT" naming the group path and the attribute.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void fail(const std::string& where, const std::string& what) const;
  /// Refuse attributes not among `rows` and members not allowed in table group `group`.
  void checkGroup(hid_t obj, const std::string& where, const std::string& group, const std::vector<Row>& rows) const;
  void checkGroup(hid_t obj, const std::string& where, const std::string& group) const {
    checkGroup(obj, where, group, rowsOf(group));
  }
  /// The group `name` of `parent` (at `path` in the file) opened and checked against the table's rows of
  /// `path`; an invalid handle when the file has no such group.
  h5::Handle group(hid_t parent, const std::string& name, const std::string& path) const;
  /// Refuse a file without a group the table marks required.
  void requireGroups(hid_t file) const;
  /// A number: the row's default when absent (required: refused), finite, within the row's bounds;
  /// Int and Whole are whole numbers, Flag 0 or 1.
  Real number(hid_t obj, const std::string& where, const Row& r, bool required = false) const;
  bool flag(hid_t obj, const std::string& where, const Row& r) const { return number(obj, where, r) == 1; }
  /// A text: the row's default when absent (required: refused), one of its choices if it has any.
  std::string text(hid_t obj, const std::string& where, const Row& r, bool required = false) const;
  /// A list of names: a string-list attribute or one comma-separated string.
  std::vector<std::string> names(hid_t obj, const std::string& where, const Row& r, bool required = false) const;
  bool has(hid_t obj, const Row& r) const;
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

/// Split a comma-separated list, trimmed, empty items dropped.
std::vector<std::string> splitList(const std::string& s);

}  // namespace tq::input_schema
