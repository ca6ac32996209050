//! Graphviz DOT view of a compiled graph: passes, resources, accesses and barriers.

use std::fmt::Write as _;

use super::compiled::{CompiledGraph, ResourceUse};
use super::resource::ResourceId;

fn escape(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

fn use_edges(out: &mut String, pass_node: &str, uses: &[ResourceUse], style: &str) {
    for u in uses {
        let res = format!("r{}", u.resource.index());
        if u.reads {
            let _ = writeln!(out, "  {res} -> {pass_node} [{style}];");
        }
        if u.writes {
            let _ = writeln!(
                out,
                "  {pass_node} -> {res} [color=red{style_sep}{style}];",
                style_sep = if style.is_empty() { "" } else { ", " }
            );
        }
        if !u.reads && !u.writes {
            // Attachment or export-only uses that neither read nor write still show the link.
            let _ = writeln!(out, "  {res} -> {pass_node} [style=dotted];");
        }
    }
}

/// Renders the compiled graph as DOT (`dot -Tsvg`): kept passes numbered in execution order,
/// culled passes gray and dashed, imported resources double-bordered, exported ones bold;
/// write edges red, and pass labels list their barriers and layout transitions.
pub fn to_dot(graph: &CompiledGraph<'_>) -> String {
    let mut out = String::from("digraph frame_graph {\n  rankdir=LR;\n  node [fontname=\"monospace\", fontsize=10];\n");
    for r in graph.resources() {
        let kind = match r.id {
            ResourceId::Image(_) => "image",
            ResourceId::Buffer(_) => "buffer",
        };
        let mut label = format!("{}\\n{kind}", escape(&r.name));
        if r.imported {
            label.push_str(if r.read_only { " (imported, read-only)" } else { " (imported)" });
        }
        if let Some(export) = r.export {
            match export {
                Some(a) => {
                    let _ = write!(label, "\\nexport → {a:?}");
                }
                None => label.push_str("\\nexported"),
            }
        }
        let peripheries = if r.imported { 2 } else { 1 };
        let style = if r.export.is_some() { "bold" } else { "solid" };
        let _ = writeln!(
            out,
            "  r{} [shape=ellipse, label=\"{label}\", peripheries={peripheries}, style={style}];",
            r.id.index()
        );
    }
    for (pos, p) in graph.passes().iter().enumerate() {
        let mut label = format!("#{pos} {}\\n{:?}", escape(&p.name), p.kind);
        if !p.barriers.is_empty() {
            let _ = write!(label, "\\n{} barrier(s)", p.barriers.len());
        }
        for b in &p.barriers.images {
            if b.old_layout != b.new_layout {
                let name = graph.resources()[b.image.index() as usize].name.as_str();
                let _ = write!(label, "\\n{}: {:?} → {:?}", escape(name), b.old_layout, b.new_layout);
            }
        }
        let _ = writeln!(out, "  p{pos} [shape=box, label=\"{label}\"];");
        use_edges(&mut out, &format!("p{pos}"), &p.uses, "");
    }
    for (i, p) in graph.culled_passes().iter().enumerate() {
        let _ = writeln!(
            out,
            "  c{i} [shape=box, style=dashed, color=gray, fontcolor=gray, label=\"{} (culled)\\n{:?}\"];",
            escape(&p.name),
            p.kind
        );
        use_edges(&mut out, &format!("c{i}"), &p.uses, "color=gray, style=dashed");
    }
    let fin = graph.final_barriers();
    if !fin.is_empty() {
        let _ = writeln!(out, "  end [shape=doublecircle, label=\"end\\n{} barrier(s)\"];", fin.len());
    }
    out.push_str("}\n");
    out
}
