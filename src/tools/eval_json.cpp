#include "eval_json.h"

#include <algorithm>
#include <cmath>
#include <iomanip>

namespace tescalib::eval {

Json jsonNumber(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

Json jsonArray(const double* v, int n) {
  Json a = Json::array();
  for (int i = 0; i < n; ++i) a.push_back(jsonNumber(v[i]));
  return a;
}

namespace {

void writeObject(std::ostream& out, const Json& j) {
  out << "{";
  for (auto it = j.begin(); it != j.end(); ++it) {
    out << (it == j.begin() ? "" : ", ") << Json(it.key()).dump() << ": ";
    writeJson(out, it.value());
  }
  out << "}";
}

void writeArray(std::ostream& out, const Json& j) {
  const bool rows =
      !j.empty() && std::all_of(j.begin(), j.end(), [](const Json& e) { return e.is_object(); });
  out << (rows ? "[\n" : "[");
  for (size_t i = 0; i < j.size(); ++i) {
    out << (i == 0 ? "" : rows ? ",\n" : ", ") << (rows ? "  " : "");
    writeJson(out, j[i]);
  }
  out << (rows ? "\n]" : "]");
}

}  // namespace

void writeJson(std::ostream& out, const Json& j) {
  if (j.is_object()) {
    writeObject(out, j);
  } else if (j.is_array()) {
    writeArray(out, j);
  } else if (j.is_number_float()) {
    const double v = j.get<double>();
    if (std::isfinite(v))
      out << std::setprecision(10) << v;
    else
      out << "null";
  } else {
    out << j.dump();  // integers, booleans, null and strings (escaped)
  }
}

}  // namespace tescalib::eval
