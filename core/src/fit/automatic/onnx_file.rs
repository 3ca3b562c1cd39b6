//! Reading an ONNX file: the part of ONNX's protobuf schema (`onnx/onnx.proto`) that a
//! graph of plain operators needs, its nodes in order, their attributes and the
//! initializers holding the weights. Everything else in the file (value types, metadata,
//! training information) is skipped as protobuf skips unknown fields. The messages are
//! declared here with prost's derive, by their field numbers in the schema, so no
//! generated code and no protobuf compiler are involved.

use std::collections::HashMap;

/// `ModelProto`: only its graph.
#[derive(Clone, PartialEq, prost::Message)]
struct ModelProto {
    #[prost(message, optional, tag = "7")]
    graph: Option<GraphProto>,
}

/// `GraphProto`: nodes in topological order and the named constant tensors.
#[derive(Clone, PartialEq, prost::Message)]
struct GraphProto {
    #[prost(message, repeated, tag = "1")]
    node: Vec<NodeProto>,
    #[prost(message, repeated, tag = "5")]
    initializer: Vec<TensorProto>,
}

/// `NodeProto`: one operator applied to named values.
#[derive(Clone, PartialEq, prost::Message)]
struct NodeProto {
    #[prost(string, repeated, tag = "1")]
    input: Vec<String>,
    #[prost(string, repeated, tag = "2")]
    output: Vec<String>,
    #[prost(string, tag = "3")]
    name: String,
    #[prost(string, tag = "4")]
    op_type: String,
    #[prost(message, repeated, tag = "5")]
    attribute: Vec<AttributeProto>,
}

/// `AttributeProto`: the integer, integer-list and string kinds (the others are skipped).
#[derive(Clone, PartialEq, prost::Message)]
struct AttributeProto {
    #[prost(string, tag = "1")]
    name: String,
    #[prost(int64, tag = "3")]
    i: i64,
    #[prost(bytes = "vec", tag = "4")]
    s: Vec<u8>,
    #[prost(int64, repeated, tag = "8")]
    ints: Vec<i64>,
}

/// `TensorProto`: dimensions, element type and the data, inline or raw little-endian.
#[derive(Clone, PartialEq, prost::Message)]
struct TensorProto {
    #[prost(int64, repeated, tag = "1")]
    dims: Vec<i64>,
    #[prost(int32, tag = "2")]
    data_type: i32,
    #[prost(float, repeated, tag = "4")]
    float_data: Vec<f32>,
    #[prost(int64, repeated, tag = "7")]
    int64_data: Vec<i64>,
    #[prost(string, tag = "8")]
    name: String,
    #[prost(bytes = "vec", tag = "9")]
    raw_data: Vec<u8>,
}

/// ONNX's element type numbers (`TensorProto.DataType`).
const FLOAT: i32 = 1;
const INT64: i32 = 7;

/// Why an ONNX file cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OnnxError {
    #[error("not an ONNX model: {0}")]
    Decode(String),
    #[error("the model has no graph")]
    NoGraph,
    #[error("initializer `{name}`: {reason}")]
    Initializer { name: String, reason: String },
}

/// A constant tensor of the graph.
#[derive(Debug, Clone, PartialEq)]
pub enum Constant {
    Float { dims: Vec<usize>, values: Vec<f32> },
    Int64 { dims: Vec<usize>, values: Vec<i64> },
}

/// One node: its operator, the names it reads and writes, its attributes.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub name: String,
    pub op: String,
    pub inputs: Vec<String>,
    pub outputs: Vec<String>,
    ints: HashMap<String, Vec<i64>>,
    strings: HashMap<String, String>,
}

impl Node {
    /// A node of integer attributes `ints`, for tests that build graphs by hand.
    #[cfg(test)]
    pub fn new(
        name: &str,
        op: &str,
        inputs: Vec<String>,
        outputs: Vec<String>,
        ints: HashMap<String, Vec<i64>>,
    ) -> Node {
        Node {
            name: name.into(),
            op: op.into(),
            inputs,
            outputs,
            ints,
            strings: HashMap::new(),
        }
    }

    /// The integer or integer-list attribute `name`, if the node has it.
    pub fn ints(&self, name: &str) -> Option<&[i64]> {
        self.ints.get(name).map(Vec::as_slice)
    }

    /// The string attribute `name`, if the node has it.
    pub fn string(&self, name: &str) -> Option<&str> {
        self.strings.get(name).map(String::as_str)
    }
}

/// A graph as the file holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct OnnxGraph {
    pub nodes: Vec<Node>,
    pub constants: HashMap<String, Constant>,
}

/// Reads `bytes` (an ONNX model file).
pub fn read_onnx(bytes: &[u8]) -> Result<OnnxGraph, OnnxError> {
    let model =
        <ModelProto as prost::Message>::decode(bytes).map_err(|e| OnnxError::Decode(e.to_string()))?;
    let graph = model.graph.ok_or(OnnxError::NoGraph)?;
    let constants = graph
        .initializer
        .into_iter()
        .map(|t| Ok((t.name.clone(), constant(t)?)))
        .collect::<Result<_, OnnxError>>()?;
    let nodes = graph
        .node
        .into_iter()
        .map(|n| {
            let mut ints = HashMap::new();
            let mut strings = HashMap::new();
            for a in n.attribute {
                if !a.s.is_empty() {
                    strings.insert(a.name.clone(), String::from_utf8_lossy(&a.s).into_owned());
                }
                let values = if a.ints.is_empty() { vec![a.i] } else { a.ints };
                ints.insert(a.name, values);
            }
            Node {
                name: n.name,
                op: n.op_type,
                inputs: n.input,
                outputs: n.output,
                ints,
                strings,
            }
        })
        .collect();
    Ok(OnnxGraph { nodes, constants })
}

fn constant(t: TensorProto) -> Result<Constant, OnnxError> {
    let fail = |reason: String| OnnxError::Initializer {
        name: t.name.clone(),
        reason,
    };
    let dims = t
        .dims
        .iter()
        .map(|&d| usize::try_from(d).map_err(|_| fail(format!("dimension {d}"))))
        .collect::<Result<Vec<_>, _>>()?;
    let count = dims
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .ok_or_else(|| fail(format!("dimensions {dims:?} overflow")))?;
    let from_raw = |size: usize| -> Result<Option<Vec<[u8; 8]>>, OnnxError> {
        if t.raw_data.is_empty() {
            return Ok(None);
        }
        if t.raw_data.len() != count * size {
            return Err(fail(format!(
                "{} bytes of data for {count} values of {size} bytes",
                t.raw_data.len()
            )));
        }
        Ok(Some(
            t.raw_data
                .chunks_exact(size)
                .map(|c| {
                    let mut word = [0u8; 8];
                    word[..size].copy_from_slice(c);
                    word
                })
                .collect(),
        ))
    };
    let (constant, len) = match t.data_type {
        FLOAT => {
            let values = match from_raw(4)? {
                Some(words) => words
                    .iter()
                    .map(|w| f32::from_le_bytes([w[0], w[1], w[2], w[3]]))
                    .collect(),
                None => t.float_data.clone(),
            };
            let len = values.len();
            (Constant::Float { dims, values }, len)
        }
        INT64 => {
            let values = match from_raw(8)? {
                Some(words) => words.iter().map(|&w| i64::from_le_bytes(w)).collect(),
                None => t.int64_data.clone(),
            };
            let len = values.len();
            (Constant::Int64 { dims, values }, len)
        }
        other => {
            return Err(fail(format!(
                "element type {other} (only float and int64 are read)"
            )))
        }
    };
    if len != count {
        return Err(fail(format!("{len} values for dimensions holding {count}")));
    }
    Ok(constant)
}

#[cfg(test)]
mod tests {
    use super::*;
    use prost::Message;

    fn attribute(name: &str, ints: &[i64]) -> AttributeProto {
        AttributeProto {
            name: name.into(),
            ints: ints.to_vec(),
            ..Default::default()
        }
    }

    #[test]
    fn a_graph_round_trips_through_protobuf() {
        let raw: Vec<u8> = [1.5f32, -2.0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let model = ModelProto {
            graph: Some(GraphProto {
                node: vec![NodeProto {
                    input: vec!["x".into(), "w".into()],
                    output: vec!["y".into()],
                    name: "conv".into(),
                    op_type: "Conv".into(),
                    attribute: vec![attribute("strides", &[2, 2]), attribute("group", &[])],
                }],
                initializer: vec![
                    TensorProto {
                        dims: vec![2, 1],
                        data_type: FLOAT,
                        name: "w".into(),
                        raw_data: raw,
                        ..Default::default()
                    },
                    TensorProto {
                        dims: vec![2],
                        data_type: INT64,
                        name: "shape".into(),
                        int64_data: vec![1, -1],
                        ..Default::default()
                    },
                ],
            }),
        };
        let graph = read_onnx(&model.encode_to_vec()).unwrap();
        let node = &graph.nodes[0];
        assert_eq!((node.op.as_str(), node.name.as_str()), ("Conv", "conv"));
        assert_eq!(node.ints("strides"), Some(&[2i64, 2][..]));
        assert_eq!(node.ints("group"), Some(&[0i64][..]));
        assert_eq!(
            graph.constants["w"],
            Constant::Float {
                dims: vec![2, 1],
                values: vec![1.5, -2.0]
            }
        );
        assert_eq!(
            graph.constants["shape"],
            Constant::Int64 {
                dims: vec![2],
                values: vec![1, -1]
            }
        );
    }

    #[test]
    fn short_raw_data_is_named() {
        let model = ModelProto {
            graph: Some(GraphProto {
                node: vec![],
                initializer: vec![TensorProto {
                    dims: vec![3],
                    data_type: FLOAT,
                    name: "bias".into(),
                    raw_data: vec![0; 8],
                    ..Default::default()
                }],
            }),
        };
        let error = read_onnx(&model.encode_to_vec()).unwrap_err();
        assert_eq!(
            error.to_string(),
            "initializer `bias`: 8 bytes of data for 3 values of 4 bytes"
        );
        assert_eq!(
            read_onnx(b"\xff\xff\xff")
                .unwrap_err()
                .to_string()
                .split(':')
                .next(),
            Some("not an ONNX model")
        );
    }
}
