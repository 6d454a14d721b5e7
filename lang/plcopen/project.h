// The PLCopen TC6 XML project model (docs/plcopen.md, "What is read"): the
// parts of a `project` document rtplc runs — POUs with their interfaces and
// bodies, global variables, and the configurations' resources, tasks and
// program instances. read_project() accepts the three namespaces in use
// (tc6_0201, tc6_0200, the legacy tc6.xsd) and the editors' habits (ST in
// `xhtml:p` CDATA or an `xhtml` element, `addData` anywhere, every position at
// 0,0, executionOrderId="0"). Anything it cannot represent is an error naming
// the element and its line:col: a project is read whole or not at all.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"
#include "common/xml_reader.h"
#include "lang/iec/iec_types.h"

namespace rtplc::lang::plcopen {


// An elementary IEC type, or a derived one (a function block type by name).
// The elementary ones are lang/iec's, in its order (iec_type()).
enum class BaseType : uint8_t {
  kBool, kSint, kInt, kDint, kLint, kUsint, kUint, kUdint, kUlint,
  kByte, kWord, kDword, kLword, kReal, kLreal, kTime, kDate, kTod, kDt, kDerived,
  kString,  // STRING (docs/st.md, "Strings"): no IEC numeric type of lang/iec
  kWString  // WSTRING: UTF-16 code units
};

inline iec::IecType iec_type(BaseType b) {
  static_assert(static_cast<int>(BaseType::kTime) == static_cast<int>(iec::IecType::kTime));
  static_assert(static_cast<int>(BaseType::kDt) == static_cast<int>(iec::IecType::kDt));
  return b == BaseType::kDerived || b == BaseType::kString || b == BaseType::kWString ? iec::IecType::kReal
                                                                                     : static_cast<iec::IecType>(b);
}

struct ArrayType;

struct TypeRef {
  BaseType base = BaseType::kReal;
  std::string derived;  // the FB or user data type name when base == kDerived
  // An inline ARRAY [..] OF ... (base == kDerived, derived empty).
  std::shared_ptr<const ArrayType> array;
  // Beremiz SVGHMI's HMI_BOOL, HMI_INT...: the elementary type, exposed to an
  // HMI (a channel the web console shows: docs/st.md, "HMI variables").
  bool hmi = false;
  // STRING[n] / STRING(n): n; 0 for a STRING of the default length.
  uint32_t string_len = 0;
  bool is_bool() const { return base == BaseType::kBool; }
};

// ARRAY [lo..hi, ...] OF element: bounds are constants. Each element is a
// variable of its own in the task image, so a task's arrays hold at most
// this many elements between them.
inline constexpr size_t kMaxArrayElements = 4096;
struct ArrayType {
  std::vector<std::pair<int64_t, int64_t>> dims;
  TypeRef element;
  // Saturates past kMaxArrayElements (the readers refuse such an array), so a
  // crafted bound never wraps the product.
  size_t size() const {
    size_t n = 1;
    for (const auto& [lo, hi] : dims) {
      const int64_t span = hi - lo + 1;
      if (span <= 0) return 0;
      if (static_cast<uint64_t>(span) > kMaxArrayElements || n > kMaxArrayElements / static_cast<size_t>(span)) {
        return kMaxArrayElements + 1;
      }
      n *= static_cast<size_t>(span);
    }
    return n;
  }
};

// "BOOL", "INT", ... or the derived name.
std::string type_name(const TypeRef& t);
// Parses "INT", "T#..." aside: an elementary type name, case-insensitive.
std::optional<BaseType> elementary_type(std::string_view name);
// True for a Beremiz SVGHMI type name (HMI_INT, hmi_bool): elementary_type()
// reads it as its elementary type.
bool is_hmi_type(std::string_view name);

enum class VarSection : uint8_t { kInput, kOutput, kInOut, kLocal, kTemp, kExternal, kGlobal };
const char* section_name(VarSection s);

struct Variable {
  std::string name;
  TypeRef type;
  VarSection section = VarSection::kLocal;
  std::string address;        // "%IX0.0", empty when not located
  std::string initial;        // the initial value's text, empty when none
  // An <arrayValue> or <structValue> initial value (arrays, structures).
  const XmlElement* initial_xml = nullptr;
  bool constant = false;      // CONSTANT section
  // 'R' or 'F': a BOOL input of a function block declared R_EDGE or F_EDGE,
  // which the body reads as the rising (falling) edge of what it is given
  // (docs/st.md, "Edge inputs").
  char edge = 0;
  SourcePos pos;
};

// A <dataType> of <types><dataTypes> (docs/plcopen.md, "User data types").
struct DataType {
  enum class Kind : uint8_t { kAlias, kEnum, kStruct, kArray } kind = Kind::kAlias;
  std::string name;
  TypeRef alias;                     // kAlias: the type it renames (a subrange's base too)
  std::vector<std::string> values;   // kEnum, in order
  std::vector<int> numbers;          // kEnum: each value's integer (given, else one past the previous, from 0)
  std::vector<Variable> members;     // kStruct
  std::shared_ptr<const ArrayType> array;  // kArray
  std::string initial;               // the type's own initial value (alias, enum)
  const XmlElement* initial_xml = nullptr;
  SourcePos pos;
};

enum class BodyLanguage : uint8_t { kNone, kFbd, kLd, kSt, kIl, kSfc };
const char* language_name(BodyLanguage l);

struct Body {
  BodyLanguage language = BodyLanguage::kNone;
  const XmlElement* graph = nullptr;  // FBD / LD / SFC: the language element
  const XmlElement* text = nullptr;   // ST / IL: the element holding the text
  std::string source;                 // ST / IL text
  SourcePos pos;
};

enum class PouType : uint8_t { kProgram, kFunctionBlock, kFunction };

// An SFC action or transition declared beside the body (<actions>, <transitions>).
struct NamedBody {
  std::string name;
  Body body;
  SourcePos pos;
};

struct Pou {
  std::string name;
  PouType type = PouType::kProgram;
  std::optional<TypeRef> return_type;  // functions
  std::vector<Variable> vars;
  Body body;
  std::vector<NamedBody> actions, transitions;  // SFC
  SourcePos pos;

  const Variable* var(std::string_view n) const;  // case-insensitive
};

struct PouInstance {
  std::string name;
  std::string type_name;
  SourcePos pos;
  // A .st file's `PROGRAM p WITH t : Main (level := %IW0, alarm => %QX0.0);`:
  // an input set from a constant, a global or a direct variable before each
  // run, an output copied to a global or a direct variable after it. `text`
  // holds the source or sink, its positions the file's.
  struct Connection {
    std::string formal;
    bool output = false;
    const XmlElement* text = nullptr;
    SourcePos pos;
  };
  std::vector<Connection> connections;
};

struct Task {
  std::string name;
  double interval = 0;         // seconds; 0 when the task has none
  int priority = 0;
  std::string single;          // the triggering variable of a `single` task
  std::vector<PouInstance> instances;
  SourcePos pos;
};

struct Resource {
  std::string name;
  std::vector<Task> tasks;
  std::vector<PouInstance> unassigned;  // pouInstance directly under the resource
  std::vector<Variable> globals;
  SourcePos pos;
};

struct Configuration {
  std::string name;
  std::vector<Resource> resources;
  std::vector<Variable> globals;
  SourcePos pos;
};

struct Project {
  XmlElement root;  // owns every element the bodies point into
  std::string ns;   // the namespace the root declared
  std::vector<Pou> pous;
  std::vector<DataType> data_types;
  std::vector<Configuration> configurations;
  // <fileHeader>'s companyName and productName: which editor wrote it.
  std::string company, product;

  const Pou* pou(std::string_view name) const;  // case-insensitive
  const DataType* data_type(std::string_view name) const;  // case-insensitive
  // The enumeration value `name` ("Run", or "Mode#Run"): its integer.
  std::optional<int> enum_value(std::string_view name) const;
};

// Parses `text` as a PLCopen project. Errors name the element and its position.
std::optional<Project> read_project(std::string_view text, DiagnosticList& diags);

// IEC literal values: TRUE/FALSE, integers (with 16#, 8#, 2#, underscores and a
// type prefix INT#), reals, TIME (T#1h2m3s4ms, TIME#..., negative), dates and
// times of day (D#2024-01-15, TOD#12:30:15.5, DT#2024-01-15-12:30:15), as a
// double (TIME and TOD in seconds, DATE and DT in seconds since 1970-01-01;
// `is_time` is set for all four). nullopt when `text` is not a literal.
// A character string literal `'text'` (also `STRING#'text'`) with its `$`
// escapes ($$ $' $L $N $P $R $T $hh): its bytes; a double-byte one `"text"`
// (`WSTRING#"text"`, escapes $" and $hhhh; `wide` set): its UTF-16 code
// units written as UTF-8 (blocks/string_ops.h utf16_units reads them back).
// nullopt with `error` set when it is none (an unknown escape, a missing quote).
std::optional<std::string> parse_string_literal(std::string_view text, std::string* error, bool* wide = nullptr);

std::optional<double> parse_literal(std::string_view text, bool* is_bool = nullptr,
                                    bool* is_time = nullptr);

// The date type a literal's prefix names (D, DATE, TOD, TIME_OF_DAY, DT,
// DATE_AND_TIME; any case), else nothing.
std::optional<iec::IecType> date_literal_type(std::string_view prefix);

bool iequals(std::string_view a, std::string_view b);
std::string upper(std::string_view s);
// An attribute's value, empty when the element has none.
std::string attr(const XmlElement& e, std::string_view name);
// A letter, digit or underscore: a character of an IEC identifier.
bool ident_char(char c);

}  // namespace rtplc::lang::plcopen
