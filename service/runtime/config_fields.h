// The service config's keys as one table: the loader (config.cc), validate() and the reference
// page (config_reference.cc) all read it, so a key, its bounds and its doc line are written once.
#pragma once

#include <string>
#include <vector>

#include "service/runtime/config.h"

namespace coopdyn::runtime {

// How a key's value is read from YAML.
enum class FieldKind {
  kReal,       // a number
  kRealOrOff,  // a number, or the word off (= 0)
  kInteger,    // an integer (read as one: 2.5 is a type error)
  kCount,      // a number that must be an integer (read as a number: 2.5 is a range error)
  kText,       // a string
  kChoice,     // one of the words in choices
  kFlag,       // true or false
};

// A value on its way between YAML and ServiceConfig, in the member its kind uses.
struct FieldValue {
  double x = 0;     // kReal, kRealOrOff, kCount
  long long n = 0;  // kInteger
  std::string s;    // kText, kChoice
  bool b = false;   // kFlag
};

struct ConfigField {
  const char* section;  // "" at the top level, else the mapping the key is in
  const char* key;
  FieldKind kind;
  const char* what;  // the type, as a message says it: "'rate_hz' must be a number (Hz)"
  double lo, hi;     // the bounds of a number, or of a text's length (0, 0: none)
  const char* range_note;  // the reference's range column beyond [lo, hi] ("" for none)
  std::vector<const char*> choices;  // kChoice: the words, in the order messages list them
  bool null_refused;                 // kChoice: `key: ~` is a bad word, not the default
  FieldValue (*get)(const ServiceConfig&);
  void (*set)(ServiceConfig&, const FieldValue&);  // kChoice: the word is one of choices
  // "" if the value may be stored in c (which holds the keys before this one), else the reason
  // with the bounds and the value given
  std::string (*check)(const ConfigField&, const FieldValue&, const ServiceConfig& c);
  const char* default_note;  // after the default in the reference
  const char* doc;           // the reference's meaning column
};

// Every key, in the order the loader reads and checks them and the reference lists them.
const std::vector<ConfigField>& config_fields();

// "receive.queue", "rate_hz"
std::string field_path(const ConfigField& f);
// "simulate or estimate", "hold, zero or damping"
std::string choice_list(const ConfigField& f);
// A number as the reference prints it: "1000", "0.005", "3600000".
std::string number_text(double x);
// A value as a config file writes it: "1000", "0.005", "COOPDYN_STATE", "false".
std::string field_text(const ConfigField& f, const FieldValue& v);

}  // namespace coopdyn::runtime
