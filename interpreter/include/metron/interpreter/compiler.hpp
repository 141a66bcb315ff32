// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "metron/grammar/ast.hpp"
#include "metron/grammar/parser.hpp"
#include "metron/interpreter/ir/instruction.hpp"
#include "metron/stdlib/diagnostic.hpp"
#include "metron/stdlib/file_access.hpp"
#include "metron/stdlib/source.hpp"

namespace metron::interpreter {

/// Orders labels with the index of an indexed label left out: `HOLE[I]`, `HOLE[2]` and `HOLE[J+1]`
/// are one family, which the compiler checks as one name (the index is known at run time only).
struct LabelLess {
  static std::string family(const std::string& label) {
    std::string out;
    int depth = 0;
    for (char c : label) {
      if (c == ']' && depth > 0) --depth;
      if (depth == 0) out += c;
      if (c == '[') ++depth;
    }
    return out;
  }
  bool operator()(const std::string& a, const std::string& b) const {
    if (a.find('[') == std::string::npos && b.find('[') == std::string::npos) return a < b;
    return family(a) < family(b);
  }
};

/// What the compiler knows about the names a program defines (kept across REPL entries).
struct SymbolTable {
  struct FeatureInfo {
    runtime::FeatureType type = runtime::FeatureType::Point;
    Span span;
  };
  struct VariableInfo {
    ValueType type = ValueType::Real;
    int size = 0;  ///< array size (all its elements), 0 for a scalar
    Span span;
    std::vector<int> dims;  ///< an array's dimensions, V[3,30]: {3, 30}; one for V[10]
  };
  std::map<std::string, FeatureInfo, LabelLess> features;
  std::map<std::string, runtime::ToleranceKind, LabelLess> tolerances;  ///< label -> kind
  std::set<std::string, LabelLess> datums, sensors, alignments, devices, saved, paths;
  std::map<std::string, VariableInfo> variables;  ///< globals
  std::map<std::string, int> macros;              ///< name -> index in Module::macros
  /// Macro name -> (parameter index -> feature type) for FEAT statements whose label is a parameter:
  /// a call defines the feature named by its argument.
  std::map<std::string, std::map<int, runtime::FeatureType>> macro_features;
  std::map<std::string, Span, LabelLess> skipped;  ///< labels defined by skipped vendor statements
  /// Features whose last CONST used a method metron does not evaluate (OFFSET, TANTO ...): label ->
  /// the method word. Read leniently, their OUTPUT is left out with a warning.
  std::map<std::string, std::string, LabelLess> unconstructed;
  /// Features of a DMIS type metron skips (FEAT/SYMPLN, COMPOUND ...): label -> the type word.
  /// Read leniently, their MEAS blocks are skipped and their OUTPUT is left out with a warning.
  std::map<std::string, std::string, LabelLess> unsupported_features;
  /// Tolerances the last OUTPUT or EVAL naming them left out, read leniently, for a feature type
  /// metron does not evaluate them for (PERP of a CIRCLE): label -> that type's word.
  std::map<std::string, std::string, LabelLess> tolerances_left_out;
  /// CONST/DIST,F(d),BF,FA(a),FA(b) (WinWerth's distance held as a feature): d -> the two feature
  /// labels, which an OUTPUT of F(d) with a tolerance reports the tolerance of.
  std::map<std::string, std::vector<grammar::Expr>, LabelLess> distance_features;
  /// F(p)=FEAT/PATERN,F(a),F(b),...: pattern label -> its features' labels (upper case), in order.
  std::map<std::string, std::vector<std::string>, LabelLess> patterns;
  std::set<std::string> units_in_progress;            ///< CALL/EXTERN cycle detection
  std::map<std::string, std::size_t> compiled_units;  ///< called file (canonical path) -> unit
  std::set<std::string, LabelLess> tolerance_datums;  ///< tolerances defined with datum references
  std::set<std::string, LabelLess>
      evaluated_tolerances;  ///< tolerances an EVAL has evaluated (OUTPUT/TA(t) alone reports them)
  /// Sensors the program takes from the machine's probe library (RECALL/SA, SNSLCT without SNSDEF).
  std::set<std::string, LabelLess> library_sensors;
  /// Tolerances of a DMIS type metron parses but does not evaluate (ANGLR, CPROFS, ...): label -> type.
  std::map<std::string, std::string, LabelLess> unevaluated_tolerances;
  /// Folders searched for CALL/EXTERN,DMIS files written with another machine's path (--include).
  std::vector<std::string> include_dirs;
};

/// What a compiled text is: a program file (or text compiled as one), or a REPL entry, which
/// may redefine names and need not start with DMISMN or end with ENDFIL.
enum class UnitKind { File, ReplEntry };

/// Compiles DMIS sources to IR: name resolution, type and semantic checks, lowering.
class Compiler {
 public:
  Compiler(SourceManager& sources, DiagnosticSink& sink);

  /// Parses and compiles a file as a new unit; returns its unit index, or nullopt when the file
  /// cannot be read. Errors go to the sink (check sink.has_errors()).
  std::optional<std::size_t> compile_file(const std::string& path, Span included_from = {},
                                          const std::string& written = {});
  /// Compiles text held in memory (a REPL entry) as a new unit with the current symbols.
  std::size_t compile_text(const std::string& name, const std::string& text, UnitKind kind = UnitKind::File);
  /// The DMIS major words the compiler knows (the statement table's rows, sorted).
  static std::vector<std::string> statement_words();

  /// Compiles one expression (the debugger's `print` and `set`) with the current symbols.
  /// `runtime_names` are variables visible at run time only (macro parameters and locals).
  std::optional<ir::Expr> compile_expression(const std::string& text, const std::set<std::string>& runtime_names = {});

  /// How files are read (default lenient: non-statement lines are warnings; docs/language.md).
  void set_parse_options(const grammar::ParseOptions& options) { m_parse_options = options; }

  [[nodiscard]] const ir::Module& module() const { return m_module; }
  [[nodiscard]] ir::Module& module() { return m_module; }
  [[nodiscard]] const SymbolTable& symbols() const { return m_symbols; }
  [[nodiscard]] SourceManager& sources() { return m_sources; }

  /// Folders a program may read besides its own (file policy) and where CALL/EXTERN,DMIS files
  /// written with another machine's path are searched.
  void set_include_dirs(std::vector<std::string> dirs) {
    m_symbols.include_dirs = dirs;
    m_include_dirs = std::move(dirs);
  }
  [[nodiscard]] const std::vector<std::string>& include_dirs() const { return m_include_dirs; }
  /// The read policy in force: set when the main program is compiled (its folder and the include
  /// folders); unrestricted before that.
  [[nodiscard]] const FileAccessPolicy& file_policy() const { return m_policy; }

 private:
  std::size_t compile_program(std::uint32_t file, const std::string& path, UnitKind kind);
  /// false (and one error said) when `file` has no DMISMN and most of its lines are not DMIS.
  bool reads_as_dmis(std::uint32_t file, const grammar::Program& program, const DiagnosticSink& parsed);
  SourceManager& m_sources;
  DiagnosticSink& m_sink;
  ir::Module m_module;
  SymbolTable m_symbols;
  grammar::ParseOptions m_parse_options;
  std::vector<std::string> m_include_dirs;
  FileAccessPolicy m_policy;
};

}  // namespace metron::interpreter
