#include "clients/python/module/inputs.h"

#include <cmath>
#include <string>

namespace coopdyn::py {

namespace {

std::string shape_text(const pyb::array& a) {
  std::string s = "(";
  for (pyb::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

[[noreturn]] void not_finite(const char* arg, const std::string& where, const std::string& name, double x) {
  throw pyb::value_error(std::string(arg) + where + " (" + name + ") is " + (std::isnan(x) ? "NaN" : "infinite") +
                         ": every value must be finite");
}

void read_dict(const pyb::dict& d, const char* arg, const std::vector<std::string>& names, Eigen::VectorXd& out) {
  for (auto item : d) {
    if (!pyb::isinstance<pyb::str>(item.first))
      throw pyb::value_error(std::string(arg) + ": keys must be names (str), got " +
                             std::string(pyb::str(pyb::repr(item.first))));
    const std::string key = item.first.cast<std::string>();
    const int i = index_of(names, key, arg, "name");
    double x;
    try {
      x = pyb::float_(pyb::reinterpret_borrow<pyb::object>(item.second)).cast<double>();
    } catch (const pyb::error_already_set&) {
      throw pyb::value_error(std::string(arg) + "['" + key +
                             "'] is not a number: " + std::string(pyb::str(pyb::repr(item.second))));
    }
    if (!std::isfinite(x))
      throw pyb::value_error(std::string(arg) + "['" + key + "'] is " + (std::isnan(x) ? "NaN" : "infinite") +
                             ": every value must be finite");
    out[i] = x;
  }
}

pyb::array_t<double> as_doubles(pyb::handle obj, const char* arg) {
  if (pyb::array_t<double>::check_(obj)) {
    auto a = pyb::reinterpret_borrow<pyb::array_t<double>>(obj);
    if (a.flags() & pyb::array::c_style) return a;
  }
  auto r = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(obj);
  if (!r)
    throw pyb::value_error(std::string(arg) + ": expected numbers (a numpy array, a sequence or a dict by name), got " +
                           std::string(pyb::str(pyb::repr(obj))).substr(0, 80));
  return r;
}

}  // namespace

int index_of(const std::vector<std::string>& names, const std::string& name, const char* arg, const char* what,
             const char* hint) {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  throw pyb::value_error(std::string(arg) + ": unknown " + what + " '" + name + "'" + hint);
}

void read_vector(pyb::handle obj, const char* arg, const std::vector<std::string>& names, const char* order,
                 Eigen::VectorXd& out) {
  if (obj.is_none()) return;
  if (pyb::isinstance<pyb::dict>(obj)) return read_dict(pyb::reinterpret_borrow<pyb::dict>(obj), arg, names, out);
  const pyb::array_t<double> a = as_doubles(obj, arg);
  const auto n = static_cast<pyb::ssize_t>(names.size());
  if (a.ndim() != 1 || a.shape(0) != n)
    throw pyb::value_error(std::string(arg) + ": expected shape (" + std::to_string(n) +
                           ",) in the order of the scene's " + order + ", got shape " + shape_text(a));
  const double* x = a.data();
  for (pyb::ssize_t i = 0; i < n; ++i)
    if (!std::isfinite(x[i])) not_finite(arg, "[" + std::to_string(i) + "]", names[static_cast<size_t>(i)], x[i]);
  out = Eigen::Map<const Eigen::VectorXd>(x, n);
}

pyb::array_t<double> read_stack(pyb::handle obj, const char* arg, const std::vector<std::string>& names,
                                const char* order, const Eigen::VectorXd& def, long* rows) {
  const auto n = static_cast<pyb::ssize_t>(names.size());
  if (obj.is_none()) {
    if (*rows < 0) throw pyb::value_error(std::string(arg) + ": needed to tell the number of states");
    pyb::array_t<double> a({static_cast<pyb::ssize_t>(*rows), n});
    double* x = a.mutable_data();
    for (long r = 0; r < *rows; ++r) Eigen::Map<Eigen::VectorXd>(x + r * n, n) = def;
    return a;
  }
  pyb::array_t<double> a = as_doubles(obj, arg);
  if (a.ndim() != 2 || a.shape(1) != n)
    throw pyb::value_error(std::string(arg) + ": expected shape (N, " + std::to_string(n) +
                           "), columns in the order of the scene's " + order + ", got shape " + shape_text(a));
  if (*rows >= 0 && a.shape(0) != *rows)
    throw pyb::value_error(std::string(arg) + ": has " + std::to_string(a.shape(0)) + " rows, the other inputs " +
                           std::to_string(*rows));
  *rows = static_cast<long>(a.shape(0));
  const double* x = a.data();
  for (pyb::ssize_t r = 0; r < a.shape(0); ++r)
    for (pyb::ssize_t i = 0; i < n; ++i)
      if (!std::isfinite(x[r * n + i]))
        not_finite(arg, "[" + std::to_string(r) + ", " + std::to_string(i) + "]", names[static_cast<size_t>(i)],
                   x[r * n + i]);
  return a;
}

}  // namespace coopdyn::py
