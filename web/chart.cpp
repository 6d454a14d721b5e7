// The SFC view's chart (see chart.h): the parsed chart, flattened to JSON.
#include "web/chart.h"

#include <string>

#include "common/text.h"
#include "lang/compiler.h"
#include "lang/sfc/builder.h"
#include "lang/sfc/lexer.h"

namespace rtplc::web {
namespace {

using lang::sfc::Expr;
using nlohmann::json;

// A condition as the operator wrote it, with parentheses only where AND binds
// an OR.
std::string condition_text(const Expr& e) {
  switch (e.op) {
    case Expr::Op::kName:
      return e.name;
    case Expr::Op::kTrue:
      return "TRUE";
    case Expr::Op::kFalse:
      return "FALSE";
    case Expr::Op::kNot: {
      const std::string k = e.kids.empty() ? "" : condition_text(e.kids[0]);
      return e.kids.empty() || e.kids[0].op == Expr::Op::kName ? "NOT " + k : "NOT (" + k + ")";
    }
    case Expr::Op::kAnd:
    case Expr::Op::kOr: {
      std::string out;
      for (const Expr& k : e.kids) {
        const bool wrap = e.op == Expr::Op::kAnd && k.op == Expr::Op::kOr;
        if (!out.empty()) out += e.op == Expr::Op::kAnd ? " AND " : " OR ";
        out += wrap ? "(" + condition_text(k) + ")" : condition_text(k);
      }
      return out;
    }
  }
  return "";
}

json names(const std::vector<lang::sfc::NameRef>& refs) {
  json out = json::array();
  for (const auto& r : refs) out.push_back(r.name);
  return out;
}

}  // namespace

Result<json> chart_json(std::string_view source) {
  if (!lang::sfc::starts_with_sfc_keyword(source)) return make_error("the task's program is not an SFC chart");
  DiagnosticList diags;
  lang::sfc::ChartIndex index;
  bool ok = false;
  const lang::sfc::Chart chart = lang::sfc::parse_chart(source, diags, &index, &ok);
  if (!ok) return make_error("the task's chart does not parse:\n" + diags.render("program", source));
  json steps = json::array();
  for (const lang::sfc::Step& s : chart.steps) {
    json actions = json::array();
    for (const lang::sfc::Action& a : s.actions) {
      actions.push_back(a.qualifier + (a.seconds ? " " + format_number(*a.seconds) + "s" : "") + " " + a.target);
    }
    steps.push_back({{"name", s.name}, {"label", chart.name + "." + s.name}, {"initial", s.initial}, {"actions", actions}});
  }
  json transitions = json::array();
  for (const lang::sfc::Transition& t : chart.transitions) {
    transitions.push_back(
        {{"name", t.name}, {"from", names(t.from)}, {"to", names(t.to)}, {"when", condition_text(t.condition)}});
  }
  return json{{"chart", chart.name}, {"steps", steps}, {"transitions", transitions}};
}

}  // namespace rtplc::web
