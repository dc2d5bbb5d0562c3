// The validated reads of solid_input.h5 against its table (input_schema.hpp).
#include "input_schema.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "h5util.hpp"

namespace tq::input_schema {

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

namespace {

bool contains(const std::vector<std::string>& v, const std::string& x) {
  for (const auto& s : v)
    if (s == x) return true;
  return false;
}

std::string joined(const std::vector<std::string>& v, const char* sep) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : sep) + s;
  return out;
}

const char* const kKindNames[] = {"float", "int", "whole", "flag", "str", "names", "data"};

std::string numberText(double x) {
  std::ostringstream os;
  os << x;
  return os.str();
}

std::string rangeText(const Row& r) {
  if (r.hasLo && r.hasHi)
    return std::string(r.loOpen ? "(" : "[") + numberText(r.lo) + ", " + numberText(r.hi) + (r.hiOpen ? ")" : "]");
  if (r.hasLo) return std::string(r.loOpen ? "> " : ">= ") + numberText(r.lo);
  return std::string(r.hiOpen ? "< " : "<= ") + numberText(r.hi);
}

std::string caseHint(const Row& r) { return r.caseKey.empty() ? "" : " (case key " + r.caseKey + ")"; }

}  // namespace

Row::Row(const Attr& a)
    : group(a.group),
      name(a.name),
      kind(a.kind),
      unit(a.unit),
      hasDefault(a.hasDefault),
      def(a.def),
      defText(a.defText),
      hasLo(a.hasLo),
      loOpen(a.loOpen),
      hasHi(a.hasHi),
      hiOpen(a.hiOpen),
      required(a.required),
      lo(a.lo),
      hi(a.hi),
      choices(splitList(a.choices)),
      models(splitList(a.models)),
      requiredBy(splitList(a.requiredBy)),
      caseKey(a.caseKey) {}

bool Row::readBy(const std::string& model) const { return models.empty() || contains(models, model); }
bool Row::requiredFor(const std::string& model) const { return required || contains(requiredBy, model); }

bool Row::operator==(const Row& o) const {
  const bool numeric = kind != Kind::Text && kind != Kind::Names && kind != Kind::Data;
  return name == o.name && kind == o.kind && unit == o.unit && hasDefault == o.hasDefault &&
         (!hasDefault || (numeric ? def == o.def : defText == o.defText)) && hasLo == o.hasLo &&
         (!hasLo || (lo == o.lo && loOpen == o.loOpen)) && hasHi == o.hasHi &&
         (!hasHi || (hi == o.hi && hiOpen == o.hiOpen)) && required == o.required && choices == o.choices &&
         models == o.models && requiredBy == o.requiredBy;
}

std::vector<Row> rowsOf(const std::string& group) {
  std::vector<Row> out;
  for (const Attr& a : kAttrs)
    if (group == a.group) out.emplace_back(a);
  return out;
}

Row parseMaterialRow(const std::string& text) {
  std::vector<std::string> f;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, '|')) f.push_back(item);
  while (f.size() < 13) f.emplace_back();  // getline drops empty trailing fields
  if (f.size() != 13 || f[0].empty())
    throw InputError("material row '" + text +
                     "' does not have the 13 fields name|kind|unit|default|lo|hi|"
                     "lo_open|hi_open|required|choices|models|required_by|case");
  Row r;
  r.group = kMaterials;
  r.name = f[0];
  bool known = false;
  for (int k = 0; k < 7; ++k)
    if (f[1] == kKindNames[k]) r.kind = Kind(k), known = true;
  if (!known) throw InputError("material row '" + text + "': kind '" + f[1] + "' is unknown");
  r.unit = f[2];
  const bool numeric = r.kind != Kind::Text && r.kind != Kind::Names && r.kind != Kind::Data;
  auto num = [&](const std::string& s) {
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end) throw InputError("material row '" + text + "': '" + s + "' is not a number");
    return v;
  };
  r.hasDefault = !f[3].empty();
  if (r.hasDefault) (numeric ? r.def = num(f[3]) : 0), r.defText = numeric ? "" : f[3];
  r.hasLo = !f[4].empty();
  if (r.hasLo) r.lo = num(f[4]);
  r.hasHi = !f[5].empty();
  if (r.hasHi) r.hi = num(f[5]);
  r.loOpen = f[6] == "1";
  r.hiOpen = f[7] == "1";
  r.required = f[8] == "1";
  r.choices = splitList(f[9]);
  r.models = splitList(f[10]);
  r.requiredBy = splitList(f[11]);
  r.caseKey = f[12];
  return r;
}

void Reader::fail(const std::string& where, const std::string& what) const {
  throw InputError("solid input '" + file_ + "', " + where + ": " + what);
}

h5::Handle Reader::group(hid_t parent, const std::string& name, const std::string& path) const {
  if (!h5::exists(parent, name)) return {};
  h5::Handle g = h5::openGroup(parent, name);
  checkGroup(g, path, path);
  return g;
}

void Reader::checkGroup(hid_t obj, const std::string& where, const std::string& group,
                        const std::vector<Row>& rows) const {
  std::vector<std::string> attrs, members;
  for (const auto& r : rows)
    if (r.kind == Kind::Data)
      members.push_back(r.name);
    else
      attrs.push_back(r.name);
  for (const Group& g : kGroups)
    if (group == g.path)
      for (const auto& m : splitList(g.members))
        if (!contains(members, m)) members.push_back(m);
  for (const auto& a : h5::attrNames(obj))
    if (!contains(attrs, a))
      fail(where, "unknown attribute '" + a + "' (allowed: " + (attrs.empty() ? "none" : joined(attrs, " ")) + ")");
  if (contains(members, "*")) return;
  for (const auto& m : h5::members(obj))
    if (!contains(members, m))
      fail(where, "unknown entry '" + m + "' (allowed: " + (members.empty() ? "none" : joined(members, " ")) + ")");
}

void Reader::requireGroups(hid_t file) const {
  for (const Group& g : kGroups)
    if (g.required && !h5::exists(file, g.path)) fail(g.path, std::string("group is required (") + g.doc + ")");
}

bool Reader::has(hid_t obj, const Row& r) const {
  return r.kind == Kind::Data ? h5::exists(obj, r.name) : h5::hasAttr(obj, r.name);
}

Real Reader::number(hid_t obj, const std::string& where, const Row& r, bool required) const {
  const std::string& key = r.name;
  if (!h5::hasAttr(obj, key)) {
    if (required || r.required) fail(where, "attribute '" + key + "' is required" + caseHint(r));
    return r.hasDefault ? r.def : 0;
  }
  Real v = 0;
  try {
    v = h5::readDoubleAttr(obj, key);
  } catch (const InputError& e) {
    fail(where, e.what());
  }
  if (!std::isfinite(v)) fail(where, "attribute '" + key + "' is not finite");
  if (r.kind == Kind::Flag && v != 0 && v != 1) fail(where, "attribute '" + key + "' must be 0 or 1");
  if ((r.kind == Kind::Int || r.kind == Kind::Whole) && v != std::floor(v))
    fail(where, key + " = " + numberText(v) + " must be a whole number" + caseHint(r));
  const bool low = r.hasLo && (v < r.lo || (r.loOpen && v == r.lo));
  const bool high = r.hasHi && (v > r.hi || (r.hiOpen && v == r.hi));
  if (low || high) {
    const std::string rng = rangeText(r);
    fail(where, key + " = " + numberText(v) + (rng[0] == '(' || rng[0] == '[' ? " must lie in " : " must be ") + rng +
                    caseHint(r));
  }
  return v;
}

std::string Reader::text(hid_t obj, const std::string& where, const Row& r, bool required) const {
  const std::string& key = r.name;
  if (!h5::hasAttr(obj, key)) {
    if (required || r.required) fail(where, "attribute '" + key + "' is required" + caseHint(r));
    return r.defText;
  }
  std::string v;
  try {
    v = h5::readStringAttr(obj, key);
  } catch (const InputError& e) {
    fail(where, e.what());
  }
  if (!r.choices.empty() && !contains(r.choices, v))
    fail(where, key + " '" + v + "' is not one of " + joined(r.choices, ", ") + caseHint(r));
  return v;
}

std::vector<std::string> Reader::names(hid_t obj, const std::string& where, const Row& r, bool required) const {
  if (!h5::hasAttr(obj, r.name)) {
    if (required || r.required) fail(where, "attribute '" + r.name + "' is required");
    return splitList(r.defText);
  }
  std::vector<std::string> raw, out;
  try {
    raw = h5::readStringListAttr(obj, r.name);
  } catch (const InputError& e) {
    fail(where, e.what());
  }
  for (const auto& s : raw)
    for (auto& item : splitList(s)) out.push_back(item);
  return out;
}

}  // namespace tq::input_schema
