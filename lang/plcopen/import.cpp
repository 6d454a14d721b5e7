// The PLCopen front end's entry point (see import.h): choose what runs, lower
// it, run the language-neutral checks.
#include "lang/plcopen/import.h"

#include <set>

#include "lang/plcopen/lowering.h"

namespace rtplc::lang::plcopen {
namespace {

struct Entry {
  std::string name;
  std::vector<PouInstance> instances;
  const Task* task = nullptr;
};

std::vector<Entry> entries(const Project& p) {
  std::vector<Entry> out;
  for (const Configuration& c : p.configurations) {
    for (const Resource& r : c.resources) {
      for (const Task& t : r.tasks) out.push_back(Entry{t.name, t.instances, &t});
      for (const PouInstance& pi : r.unassigned) out.push_back(Entry{pi.name, {pi}, nullptr});
    }
  }
  return out;
}

std::string choices(const Project& p) {
  std::string s;
  for (const Entry& e : entries(p)) {
    s += s.empty() ? "" : ", ";
    s += (e.task ? "task " : "instance ") + e.name;
  }
  for (const Pou& pou : p.pous) {
    if (pou.type != PouType::kProgram) continue;
    s += s.empty() ? "" : ", ";
    s += "program " + pou.name;
  }
  return s.empty() ? "none: the project has no program" : s;
}

// A POU the chosen task does not reach is compiled anyway, on its own, so an
// error in its body is not hidden behind "OK" (a library file, a second
// program): a program as an instance of its own, a function block as an
// instance called once, a function called once, each with a variable of the
// formal's type for every VAR_IN_OUT (and every function input). What it
// cannot compile is a warning naming the POU (`--werror` makes it fatal): the
// task does not run it, so it does not stop the task. A POU whose VAR_IN_OUT
// or function input is a structure, an array or a function block is not
// checked this way (it cannot be called with a plain variable).
void check_unreached(const Project& p, std::set<const Pou*> seen, EditorSemantics sem,
                     const std::vector<const Variable*>& globals, DiagnosticList& diags) {
  std::set<std::pair<std::pair<uint32_t, uint32_t>, std::string>> said;
  for (const Pou& pou : p.pous) {
    if (seen.count(&pou)) continue;
    Pou wrapper;
    XmlElement text;
    const Pou* run = &pou;
    if (pou.type != PouType::kProgram) {
      wrapper.name = "$check";
      wrapper.type = PouType::kProgram;
      wrapper.pos = pou.pos;
      std::string args;
      bool plain = true;
      for (const Variable& v : pou.vars) {
        const bool in_out = v.section == VarSection::kInOut;
        if (!in_out && !(pou.type == PouType::kFunction && v.section == VarSection::kInput)) continue;
        if (v.type.base == BaseType::kDerived) {
          const DataType* dt = v.type.array ? nullptr : p.data_type(v.type.derived);
          if (v.type.array || !dt || dt->kind == DataType::Kind::kStruct || dt->kind == DataType::Kind::kArray) {
            plain = false;
            break;
          }
        }
        Variable a = v;
        a.name = "chk_" + v.name;
        a.section = VarSection::kLocal;
        a.address.clear();
        a.initial.clear();
        a.initial_xml = nullptr;
        a.edge = 0;
        wrapper.vars.push_back(a);
        args += (args.empty() ? "" : ", ") + v.name + " := chk_" + v.name;
      }
      if (!plain) continue;
      std::string call = pou.name;
      if (pou.type == PouType::kFunctionBlock) {
        Variable inst;
        inst.name = "chk_instance";
        inst.type.base = BaseType::kDerived;
        inst.type.derived = pou.name;
        inst.pos = pou.pos;
        wrapper.vars.push_back(inst);
        call = "chk_instance";
      }
      text.name = "ST";
      text.text = call + "(" + args + ");";
      text.pos = pou.pos;
      text.text_anchors.push_back({0, pou.pos});
      wrapper.body.language = BodyLanguage::kSt;
      wrapper.body.text = &text;
      wrapper.body.source = text.text;
      wrapper.body.pos = pou.pos;
      run = &wrapper;
    }
    CheckedProgram scratch;
    DiagnosticList d;
    Lowering L(p, scratch, d);
    L.set_semantics(sem);
    L.set_globals(globals);
    L.program_instance(*run, pou.name);
    if (!d.has_errors()) (void)L.finish();
    for (const Pou* q : L.lowered_pous()) seen.insert(q);
    for (const Diagnostic& e : d.items()) {
      if (e.severity != Severity::kError) continue;
      if (!said.insert({{e.pos.line, e.pos.col}, e.message}).second) break;
      diags.warning(e.pos, std::string(pou.type == PouType::kProgram ? "program" : pou.type == PouType::kFunction
                                                                                      ? "function"
                                                                                      : "function block") +
                               " '" + pou.name + "' (not run by this task) does not compile: " +
                               e.message);
      break;  // the first error; what follows it may be its consequence
    }
  }
}

}  // namespace

bool is_plcopen_source(std::string_view text) {
  size_t i = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") i = 3;
  for (;;) {
    while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
    if (text.substr(i, 2) == "<?" || text.substr(i, 4) == "<!--") {
      const bool pi = text.substr(i, 2) == "<?";
      const size_t e = text.find(pi ? "?>" : "-->", i);
      if (e == std::string_view::npos) return false;
      i = e + (pi ? 2 : 3);
      continue;
    }
    break;
  }
  if (text.substr(i, 1) != "<") return false;
  std::string_view rest = text.substr(i + 1);
  const size_t colon = rest.find_first_of(":> \t\r\n/");
  if (colon != std::string_view::npos && rest[colon] == ':') rest = rest.substr(colon + 1);
  return rest.substr(0, 7) == "project";
}

ImportResult import_plcopen(std::string_view xml, const ImportOptions& opt, DiagnosticList& diags) {
  std::optional<Project> proj = read_project(xml, diags);
  if (!proj) return {};
  return import_project(*proj, opt, diags);
}

ImportResult import_project(const Project& p, const ImportOptions& opt, DiagnosticList& diags) {
  ImportResult res;

  // What runs.
  std::vector<Entry> es = entries(p);
  Entry chosen;
  bool found = false;
  if (!opt.entry.empty()) {
    for (const Entry& e : es) {
      if (!found && iequals(e.name, opt.entry)) {
        chosen = e;
        found = true;
      }
    }
    if (!found) {
      for (const Entry& e : es) {
        for (const PouInstance& pi : e.instances) {
          if (!found && iequals(pi.name, opt.entry)) {
            chosen = Entry{pi.name, {pi}, e.task};
            found = true;
          }
        }
      }
    }
    if (!found) {
      if (const Pou* pou = p.pou(opt.entry); pou && pou->type == PouType::kProgram) {
        chosen = Entry{pou->name, {PouInstance{pou->name, pou->name, pou->pos, {}}}, nullptr};
        found = true;
      }
    }
    if (!found) {
      diags.error(SourcePos{}, "the project has no task, program instance or program named '" + opt.entry +
                                   "' (it has " + choices(p) + ")");
      return res;
    }
  } else {
    std::vector<Entry> runnable;
    for (const Entry& e : es) {
      if (!e.instances.empty()) runnable.push_back(e);
    }
    if (runnable.size() == 1) {
      chosen = runnable[0];
    } else if (runnable.empty()) {
      const Pou* only = nullptr;
      int programs = 0;
      for (const Pou& pou : p.pous) {
        if (pou.type == PouType::kProgram) {
          only = &pou;
          ++programs;
        }
      }
      if (programs != 1) {
        diags.error(SourcePos{}, programs == 0 ? "the project has no program POU to run"
                                               : "the project has several programs and no task; choose one "
                                                 "(" + choices(p) + ")");
        return res;
      }
      chosen = Entry{only->name, {PouInstance{only->name, only->name, only->pos, {}}}, nullptr};
    } else {
      diags.error(SourcePos{}, "the project has several tasks; choose one (" + choices(p) +
                                   "): `program_instance:` in the runtime config, --entry on the command line");
      return res;
    }
  }
  if (chosen.instances.empty()) {
    diags.error(chosen.task ? chosen.task->pos : SourcePos{}, "task '" + chosen.name + "' runs no program instance");
    return res;
  }
  res.entry = chosen.name;
  if (!chosen.task && !p.configurations.empty()) {
    res.program.notes.push_back("program instance " + chosen.name +
                                " is in no task: it runs once per cycle of the runtime task, at that task's "
                                "period (the runtime config's, else the default)");
  }
  if (chosen.task) {
    res.priority = chosen.task->priority;
    std::string ins;
    for (const PouInstance& pi : chosen.instances) ins += (ins.empty() ? "" : ", ") + pi.name;
    res.program.notes.push_back("task " + chosen.task->name + " (line " + std::to_string(chosen.task->pos.line) +
                                "): runs " + ins + "; interval " +
                                (chosen.task->interval > 0 ? std::to_string(chosen.task->interval) + " s" : "none (default period)") +
                                (chosen.task->single.empty() ? std::string()
                                                             : "; event task: the body runs in the cycles " +
                                                                   chosen.task->single + " rises (checked every period)") +
                                ", PLCopen priority " + std::to_string(chosen.task->priority) +
                                " (the runtime config's `priority` sets the SCHED_FIFO priority)");
    if (chosen.task->interval > 0) {
      res.program.period = chosen.task->interval;
      res.program.period_from_stime = true;
      res.program.stime_pos = chosen.task->pos;
      res.program.period_source = "task interval";
    }
  }

  Lowering L(p, res.program, diags);
  EditorSemantics sem = EditorSemantics::kMatiec;
  {
    // Whose semantics (docs/plcopen.md, "Which editor's semantics").
    const auto contains = [](const std::string& text, const char* what) {
      return upper(text).find(what) != std::string::npos;
    };
    const bool codesys_header = contains(p.product, "CODESYS") || contains(p.company, "CODESYS") ||
                                contains(p.company, "3S-SMART");
    sem = opt.semantics;
    std::string why;
    if (sem == EditorSemantics::kFromHeader) {
      sem = codesys_header ? EditorSemantics::kCodesys : EditorSemantics::kMatiec;
      why = p.product.empty() && p.company.empty()
                ? "no editor named in the file"
                : "the file header names " + (p.product.empty() ? p.company : p.product);
    } else {
      why = "chosen by --semantics or the task's semantics key";
    }
    L.set_semantics(sem);
    res.program.notes.push_back(std::string("semantics: ") +
                                (sem == EditorSemantics::kCodesys
                                     ? "CODESYS's (SFC: actions first, steps switch for the next cycle)"
                                     : "MatIEC's, as Beremiz and OpenPLC run (SFC: transitions first, the "
                                       "new steps' actions in the same cycle)") +
                                " - " + why);
  }
  std::vector<const Variable*> globals;
  for (const Configuration& c : p.configurations) {
    for (const Variable& v : c.globals) globals.push_back(&v);
    for (const Resource& r : c.resources) {
      for (const Variable& v : r.globals) globals.push_back(&v);
    }
  }
  L.set_globals(globals);
  if (chosen.task && !chosen.task->single.empty()) L.set_trigger(chosen.task->single, chosen.task->pos);
  for (const PouInstance& pi : chosen.instances) {
    const Pou* pou = p.pou(pi.type_name);
    if (!pou) {
      diags.error(pi.pos, "pouInstance '" + pi.name + "' names POU '" + pi.type_name + "', which the project does not define");
      continue;
    }
    if (pou->type != PouType::kProgram) {
      diags.error(pi.pos, "pouInstance '" + pi.name + "' is a " +
                              (pou->type == PouType::kFunction ? "function" : "function block") +
                              "; a task runs programs");
      continue;
    }
    res.instances.push_back(pi.name);
    L.program_instance(*pou, pi.name, pi.connections);
    if (diags.has_errors()) return res;
  }
  if (diags.has_errors() || !L.finish()) return res;
  check_unreached(p, L.lowered_pous(), sem, globals, diags);
  return res;
}

}  // namespace rtplc::lang::plcopen
