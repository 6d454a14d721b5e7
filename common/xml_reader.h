// A small, strict XML reader, shared by the PNML importer (lang/petri/pnml.cpp)
// and the PLCopen importer (lang/plcopen/project.cpp): elements,
// attributes, character data, comments, CDATA, processing instructions and the
// predefined and numeric character references. A DOCTYPE is skipped (no entity
// definitions are expanded, so no "billion laughs"). Every element and attribute
// carries its line:col, and every error names the position where reading stopped.
//
// Limits keep hostile input cheap: nesting depth, and the caller's file size.
// Element names keep only their local part ("pnml:place" -> "place",
// "xhtml:p" -> "p"): both formats put their namespace on the root and never mix
// vocabularies that clash; attributes keep their full name ("xmlns").
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/diagnostic.h"

namespace rtplc {

struct XmlAttribute {
  std::string name;
  std::string value;
  SourcePos pos;
};

struct XmlElement {
  std::string name;
  std::vector<XmlAttribute> attributes;
  std::vector<XmlElement> children;
  std::string text;  // the element's own character data, concatenated
  SourcePos pos;
  // Where each run of `text` starts in the file (a run is CDATA, plain
  // characters or one reference), so a language embedded in the text (PLCopen
  // ST bodies) can report file positions.
  struct TextAnchor {
    size_t offset;
    SourcePos pos;
  };
  std::vector<TextAnchor> text_anchors;

  // The file position of text offset `offset` (the element's own position
  // when it has no text).
  SourcePos text_position(size_t offset) const;

  const XmlAttribute* attribute(std::string_view n) const;
  const XmlElement* child(std::string_view n) const;
};

inline constexpr size_t kMaxXmlDepth = 200;

// Parses one document; on error returns nullopt with at least one diagnostic.
std::optional<XmlElement> parse_xml(std::string_view text, DiagnosticList& diags);

// Escapes &, <, >, " and ' for attribute values and character data.
std::string xml_escape(std::string_view s);

}  // namespace rtplc
