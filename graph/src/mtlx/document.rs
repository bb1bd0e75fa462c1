//! The MaterialX document model and its parser: `<materialx>` with nodedefs, nodegraphs,
//! top-level nodes and outputs, materials and looks, every element with its position.
//!
//! This module owns reading XML text into [`Document`] (versions, inherited `fileprefix` and
//! `colorspace`, the 1.38 `channels` attribute kept as written); it must not resolve
//! nodedefs or check types: the resolver and the translator do. Libraries are documents too.

use super::error::{MtlxError, Pos};
use roxmltree::Node;

/// One `<input>` (of a node, a nodedef or a nodegraph's interface).
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    /// Its name.
    pub name: String,
    /// Its MaterialX type (empty when not written).
    pub ty: String,
    /// `value`, with the inherited `fileprefix` applied to filenames.
    pub value: Option<String>,
    /// `nodename`: a connection to a node in the same scope.
    pub nodename: Option<String>,
    /// `nodegraph`: a connection to a nodegraph's output (document scope).
    pub nodegraph: Option<String>,
    /// `output`: which output of `nodename` / `nodegraph`.
    pub output: Option<String>,
    /// `interfacename`: the enclosing nodegraph's input.
    pub interfacename: Option<String>,
    /// `channels` (1.38 swizzle), as written.
    pub channels: Option<String>,
    /// `colorspace` (inherited from the enclosing elements), recorded.
    pub colorspace: Option<String>,
    /// `defaultgeomprop` (nodedef inputs): the stream an unset input reads.
    pub defaultgeomprop: Option<String>,
    /// Position of the element.
    pub pos: Pos,
}

/// A node instance.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeElem {
    /// Its category: the element name (`add`, `image`, …).
    pub category: String,
    /// Its name.
    pub name: String,
    /// Its output type (`multioutput` for several).
    pub ty: String,
    /// An explicit `nodedef` attribute.
    pub nodedef: Option<String>,
    /// Its inputs.
    pub inputs: Vec<Input>,
    /// Position.
    pub pos: Pos,
}

/// An `<output>` of a nodegraph or of the document, or a nodedef's output declaration.
pub type Output = Input;

/// A `<nodegraph>`: nodes with an interface (`<input>`s) and outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Graph {
    /// Its name.
    pub name: String,
    /// The nodedef it implements, if any.
    pub nodedef: Option<String>,
    /// Interface inputs declared on the graph itself.
    pub inputs: Vec<Input>,
    /// Its nodes.
    pub nodes: Vec<NodeElem>,
    /// Its outputs.
    pub outputs: Vec<Output>,
    /// Position.
    pub pos: Pos,
}

/// A `<nodedef>`.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeDefElem {
    /// Its name (`ND_add_color3`).
    pub name: String,
    /// The node category it defines (`add`).
    pub node: String,
    /// Its node group (`math`, `geometric`, …).
    pub group: String,
    /// Its inputs with defaults.
    pub inputs: Vec<Input>,
    /// Its outputs (name, type).
    pub outputs: Vec<Output>,
    /// The nodedef it `inherit`s inputs and outputs from (resolved by the library).
    pub inherit: Option<String>,
    /// Position.
    pub pos: Pos,
}

/// A `<look>` and its `<materialassign>`s: (material, geometry).
#[derive(Clone, Debug, PartialEq)]
pub struct Look {
    /// The look's name.
    pub name: String,
    /// (material name, geom expression) per assignment.
    pub assigns: Vec<(String, String)>,
}

/// A parsed document.
#[derive(Clone, Debug, PartialEq)]
pub struct Document {
    /// The file, as used in messages.
    pub file: String,
    /// `(major, minor)` of the `version` attribute.
    pub version: (u32, u32),
    /// The document's `colorspace`, recorded.
    pub colorspace: Option<String>,
    /// Nodedefs the document declares.
    pub nodedefs: Vec<NodeDefElem>,
    /// Nodegraphs.
    pub graphs: Vec<Graph>,
    /// Top-level nodes (materials and shaders included).
    pub nodes: Vec<NodeElem>,
    /// Top-level outputs.
    pub outputs: Vec<Output>,
    /// Looks.
    pub looks: Vec<Look>,
    /// `<implementation nodedef=… nodegraph=…>`: nodedefs implemented by a nodegraph named
    /// elsewhere (nodedef, nodegraph).
    pub implementations: Vec<(String, String)>,
    /// `<implementation … target=…>` in a shading language: a function in a file or an
    /// inline source template (what MaterialX's code generators use).
    pub code: Vec<CodeImpl>,
}

/// An implementation of a nodedef in a shading language (`target`, e.g. `genosl`): the
/// function `function` of source file `file` (relative to the document's folder), or the
/// inline template `sourcecode` (`{{input}}` naming the nodedef's inputs).
#[derive(Clone, Debug, PartialEq)]
pub struct CodeImpl {
    /// The nodedef implemented.
    pub nodedef: String,
    /// The code generator it is for.
    pub target: String,
    /// Source file, where the implementation is a function.
    pub file: Option<String>,
    /// The function's name in `file`.
    pub function: Option<String>,
    /// The inline template, where it is one.
    pub sourcecode: Option<String>,
    /// Position.
    pub pos: Pos,
}

impl Document {
    /// The material nodes (`surfacematerial`, `volumematerial`), by name.
    pub fn materials(&self) -> impl Iterator<Item = &NodeElem> {
        self.nodes.iter().filter(|n| n.ty == "material")
    }
}

/// Elements that are neither nodes nor handled here.
const NOT_NODES: &[&str] = &[
    "typedef",
    "implementation",
    "backdrop",
    "collection",
    "geominfo",
    "propertyset",
    "propertysetassign",
    "variantset",
    "variantassign",
    "token",
    "attributedef",
    "targetdef",
    "unitdef",
    "unittypedef",
    "member",
    "comment",
    "geompropdef",
    "visibility",
    "materialassign",
];

struct Ctx<'a> {
    file: &'a str,
    text: &'a str,
    /// Byte offsets where each line starts: positions by binary search.
    /// (`roxmltree::Document::text_pos_at` scans from the start of the text each time,
    /// which made reading the libraries quadratic: 88 % of the load time.)
    line_starts: Vec<usize>,
}

impl Ctx<'_> {
    fn pos(&self, n: Node) -> Pos {
        let at = n.range().start.min(self.text.len());
        let line = self.line_starts.partition_point(|&s| s <= at).max(1);
        let start = self.line_starts[line - 1];
        let column = self
            .text
            .get(start..at)
            .map_or(at - start, |s| s.chars().count())
            + 1;
        Pos {
            file: self.file.to_string(),
            line: line as u32,
            column: column as u32,
        }
    }

    fn err(&self, n: Node, msg: impl Into<String>) -> MtlxError {
        MtlxError::Document {
            at: self.pos(n),
            msg: msg.into(),
        }
    }

    fn name(&self, n: Node) -> Result<String, MtlxError> {
        match n.attribute("name") {
            Some(s) if !s.is_empty() && !s.contains(['.', '/', '$']) => Ok(s.to_string()),
            Some(s) => Err(self.err(
                n,
                format!(
                    "<{}> name `{s}` is invalid (empty, or has `.`, `/` or `$`)",
                    n.tag_name().name()
                ),
            )),
            None => Err(self.err(
                n,
                format!("<{}> has no name attribute", n.tag_name().name()),
            )),
        }
    }

    fn input(&self, n: Node, inherited: &Scope) -> Result<Input, MtlxError> {
        let attr = |k: &str| n.attribute(k).map(str::to_string);
        let ty = attr("type").unwrap_or_default();
        let mut value = attr("value");
        if let (Some(v), "filename", Some(prefix)) = (&value, ty.as_str(), &inherited.fileprefix)
            && !v.is_empty()
        {
            value = Some(format!("{prefix}{v}"));
        }
        Ok(Input {
            name: self.name(n)?,
            ty,
            value,
            nodename: attr("nodename").filter(|s| !s.is_empty()),
            nodegraph: attr("nodegraph").filter(|s| !s.is_empty()),
            output: attr("output").filter(|s| !s.is_empty()),
            interfacename: attr("interfacename").filter(|s| !s.is_empty()),
            channels: attr("channels").filter(|s| !s.is_empty()),
            colorspace: attr("colorspace").or_else(|| inherited.colorspace.clone()),
            defaultgeomprop: attr("defaultgeomprop"),
            pos: self.pos(n),
        })
    }

    fn node(&self, n: Node, scope: &Scope) -> Result<NodeElem, MtlxError> {
        let scope = scope.enter(n);
        let mut inputs = Vec::new();
        for c in n.children().filter(Node::is_element) {
            if c.tag_name().name() == "input" {
                let i = self.input(c, &scope)?;
                if inputs.iter().any(|x: &Input| x.name == i.name) {
                    return Err(self.err(c, format!("input `{}` is set twice", i.name)));
                }
                inputs.push(i);
            }
        }
        Ok(NodeElem {
            category: n.tag_name().name().to_string(),
            name: self.name(n)?,
            ty: n.attribute("type").unwrap_or("").to_string(),
            nodedef: n.attribute("nodedef").map(str::to_string),
            inputs,
            pos: self.pos(n),
        })
    }

    fn graph(&self, n: Node, scope: &Scope) -> Result<Graph, MtlxError> {
        let scope = scope.enter(n);
        let mut g = Graph {
            name: self.name(n)?,
            nodedef: n.attribute("nodedef").map(str::to_string),
            inputs: Vec::new(),
            nodes: Vec::new(),
            outputs: Vec::new(),
            pos: self.pos(n),
        };
        for c in n.children().filter(Node::is_element) {
            match c.tag_name().name() {
                "input" => g.inputs.push(self.input(c, &scope)?),
                "output" => g.outputs.push(self.input(c, &scope)?),
                "nodegraph" => {
                    return Err(self.err(c, "a nodegraph inside a nodegraph is not allowed"));
                }
                t if NOT_NODES.contains(&t) => {}
                _ => g.nodes.push(self.node(c, &scope)?),
            }
        }
        Ok(g)
    }

    fn nodedef(&self, n: Node, scope: &Scope) -> Result<NodeDefElem, MtlxError> {
        let mut d = NodeDefElem {
            name: self.name(n)?,
            node: n
                .attribute("node")
                .ok_or_else(|| self.err(n, "<nodedef> has no node attribute"))?
                .to_string(),
            group: n.attribute("nodegroup").unwrap_or("").to_string(),
            inputs: Vec::new(),
            outputs: Vec::new(),
            inherit: n.attribute("inherit").map(str::to_string),
            pos: self.pos(n),
        };
        for c in n.children().filter(Node::is_element) {
            match c.tag_name().name() {
                "input" => d.inputs.push(self.input(c, scope)?),
                "output" => d.outputs.push(self.input(c, scope)?),
                _ => {}
            }
        }
        Ok(d)
    }
}

/// Attributes inherited by descendants.
#[derive(Clone, Default)]
struct Scope {
    fileprefix: Option<String>,
    colorspace: Option<String>,
}

impl Scope {
    fn enter(&self, n: Node) -> Scope {
        Scope {
            fileprefix: n
                .attribute("fileprefix")
                .map(str::to_string)
                .or_else(|| self.fileprefix.clone()),
            colorspace: n
                .attribute("colorspace")
                .map(str::to_string)
                .or_else(|| self.colorspace.clone()),
        }
    }
}

fn version(ctx: &Ctx, root: Node) -> Result<(u32, u32), MtlxError> {
    let Some(v) = root.attribute("version") else {
        return Err(ctx.err(root, "<materialx> has no version attribute"));
    };
    let mut it = v.trim().split('.');
    let major = it.next().and_then(|s| s.parse::<u32>().ok());
    let minor = it.next().and_then(|s| s.parse::<u32>().ok());
    match (major, minor) {
        (Some(1), Some(m @ 38..)) => Ok((1, m)),
        _ => Err(MtlxError::Version {
            at: ctx.pos(root),
            version: v.to_string(),
        }),
    }
}

/// Parses a MaterialX document from its text; `file` names it in errors.
pub fn parse(file: &str, text: &str) -> Result<Document, MtlxError> {
    let opts = roxmltree::ParsingOptions {
        allow_dtd: false,
        nodes_limit: 1 << 22,
        ..roxmltree::ParsingOptions::default()
    };
    let doc = roxmltree::Document::parse_with_options(text, opts).map_err(|e| {
        let p = e.pos();
        MtlxError::Xml {
            at: Pos {
                file: file.to_string(),
                line: p.row,
                column: p.col,
            },
            source: e,
        }
    })?;
    let line_starts = std::iter::once(0)
        .chain(text.match_indices('\n').map(|(i, _)| i + 1))
        .collect();
    let ctx = Ctx {
        file,
        text,
        line_starts,
    };
    let root = doc.root_element();
    if root.tag_name().name() != "materialx" {
        return Err(ctx.err(
            root,
            format!(
                "the root element is <{}>, not <materialx>",
                root.tag_name().name()
            ),
        ));
    }
    let version = version(&ctx, root)?;
    let scope = Scope::default().enter(root);
    let mut d = Document {
        file: file.to_string(),
        version,
        colorspace: root.attribute("colorspace").map(str::to_string),
        nodedefs: Vec::new(),
        graphs: Vec::new(),
        nodes: Vec::new(),
        outputs: Vec::new(),
        looks: Vec::new(),
        implementations: Vec::new(),
        code: Vec::new(),
    };
    for c in root.children().filter(Node::is_element) {
        match c.tag_name().name() {
            "nodedef" => d.nodedefs.push(ctx.nodedef(c, &scope)?),
            "nodegraph" => d.graphs.push(ctx.graph(c, &scope)?),
            "output" => d.outputs.push(ctx.input(c, &scope)?),
            "look" => d.looks.push(Look {
                name: ctx.name(c)?,
                assigns: c
                    .children()
                    .filter(|a| a.tag_name().name() == "materialassign")
                    .map(|a| {
                        (
                            a.attribute("material").unwrap_or("").to_string(),
                            a.attribute("geom").unwrap_or("").to_string(),
                        )
                    })
                    .collect(),
            }),
            "implementation" => {
                if let (Some(nd), Some(ng)) = (c.attribute("nodedef"), c.attribute("nodegraph")) {
                    d.implementations.push((nd.to_string(), ng.to_string()));
                } else if let (Some(nd), Some(target)) =
                    (c.attribute("nodedef"), c.attribute("target"))
                {
                    let attr = |a: &str| c.attribute(a).map(str::to_string);
                    d.code.push(CodeImpl {
                        nodedef: nd.to_string(),
                        target: target.to_string(),
                        file: attr("file"),
                        function: attr("function"),
                        sourcecode: attr("sourcecode"),
                        pos: ctx.pos(c),
                    });
                }
            }
            t if NOT_NODES.contains(&t) => {}
            _ => d.nodes.push(ctx.node(c, &scope)?),
        }
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_graphs_inputs_and_inherited_attributes() {
        let d = parse(
            "t.mtlx",
            r#"<?xml version="1.0"?>
<materialx version="1.38" colorspace="lin_rec709" fileprefix="tex/">
  <nodegraph name="NG">
    <input name="scale" type="float" value="2" />
    <image name="img" type="color3">
      <input name="file" type="filename" value="a.png" colorspace="srgb_texture" />
    </image>
    <multiply name="m" type="color3">
      <input name="in1" type="color3" nodename="img" channels="rgb" />
      <input name="in2" type="float" interfacename="scale" />
    </multiply>
    <output name="out" type="color3" nodename="m" />
  </nodegraph>
  <surfacematerial name="Mat" type="material" />
  <look name="L"><materialassign name="a" material="Mat" geom="/box" /></look>
</materialx>"#,
        )
        .unwrap();
        assert_eq!(d.version, (1, 38));
        let g = &d.graphs[0];
        let file = &g.nodes[0].inputs[0];
        assert_eq!(file.value.as_deref(), Some("tex/a.png"));
        assert_eq!(file.colorspace.as_deref(), Some("srgb_texture"));
        assert_eq!(g.nodes[1].inputs[0].channels.as_deref(), Some("rgb"));
        assert_eq!(g.nodes[1].inputs[1].interfacename.as_deref(), Some("scale"));
        assert_eq!(
            g.nodes[1].inputs[1].colorspace.as_deref(),
            Some("lin_rec709")
        );
        assert_eq!(g.outputs[0].pos.line, 12);
        assert_eq!(d.materials().count(), 1);
        assert_eq!(d.looks[0].assigns, vec![("Mat".into(), "/box".into())]);
    }

    #[test]
    fn malformed_xml_names_line_and_column() {
        let e = parse(
            "bad.mtlx",
            "<materialx version=\"1.39\">\n  <add name=\"a\">\n</materialx>",
        )
        .unwrap_err();
        let text = e.to_string();
        assert!(text.starts_with("bad.mtlx:3:"), "{text}");
        assert!(text.contains("malformed XML"), "{text}");
    }

    #[test]
    fn old_versions_are_named() {
        let e = parse("old.mtlx", "<materialx version=\"1.37\"/>").unwrap_err();
        assert!(
            e.to_string()
                .contains("MaterialX version 1.37 is not supported"),
            "{e}"
        );
        let e = parse("x.mtlx", "<materialx/>").unwrap_err();
        assert!(e.to_string().contains("no version"), "{e}");
    }

    /// Positions come from a line index, not roxmltree's scan from the start; they must be
    /// the same line and column (in characters) for every element, with multi-byte text
    /// and CRLF line ends before it.
    #[test]
    fn positions_match_roxmltree() {
        let text = "<?xml version=\"1.0\"?>\r\n<!-- é ü ∑ -->\r\n<materialx version=\"1.39\">\n  \
                    <nodegraph name=\"g\">\n    <add name=\"ä\" type=\"float\">\n      \
                    <input name=\"in1\" type=\"float\" value=\"1\"/></add>\n  </nodegraph>\n\
                    </materialx>\n";
        let doc = roxmltree::Document::parse(text).unwrap();
        let line_starts = std::iter::once(0)
            .chain(text.match_indices('\n').map(|(i, _)| i + 1))
            .collect();
        let ctx = Ctx {
            file: "t.mtlx",
            text,
            line_starts,
        };
        let mut n = 0;
        for node in doc.descendants().filter(|x| x.is_element()) {
            let want = doc.text_pos_at(node.range().start);
            let got = ctx.pos(node);
            assert_eq!((got.line, got.column), (want.row, want.col), "{node:?}");
            n += 1;
        }
        assert_eq!(n, 4);
    }
}
