//! A small convolutional network run on the CPU: the operators of MediaPipe's face landmark
//! network as ONNX holds it (`Conv` plain, grouped and depthwise with strides, dilations
//! and padding; `Relu`, `PRelu`, `Add`, `MaxPool`, constant `Pad` and `Reshape`), for one
//! picture at a time in NCHW order (N = 1). Shapes are worked out and checked once, when
//! the network is built from the file.
//!
//! A convolution without groups is one matrix product (faer): the weights times the input's
//! taps gathered column by column (for a 1 x 1 kernel, the planes themselves). A grouped
//! or depthwise one adds one weighted, shifted copy of an input plane per kernel tap
//! (`out[y][x] += w * in[y·s + dy][x·s + dx]`), the rows' valid spans worked out once per
//! tap ([`Window::sweep`]), its output channels shared among rayon's threads.

use std::collections::HashMap;

use rayon::prelude::*;

use super::onnx_file::{Constant, Node, OnnxGraph};

/// Why a network cannot be built or run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NetError {
    #[error("node `{node}` ({op}): {reason}")]
    Node {
        node: String,
        op: String,
        reason: String,
    },
    #[error("the network has no value `{0}` to give as an output")]
    Output(String),
    #[error("the network takes {expected} input values, not {found}")]
    Input { expected: usize, found: usize },
}

/// Channels, rows and columns of one value (N = 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    pub channels: usize,
    pub rows: usize,
    pub columns: usize,
}

impl Shape {
    fn plane(self) -> usize {
        self.rows * self.columns
    }

    fn len(self) -> usize {
        self.channels * self.plane()
    }
}

/// Rows and columns added before and after, each side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Padding {
    top: usize,
    left: usize,
    bottom: usize,
    right: usize,
}

/// A window swept over the planes: kernel, stride, dilation and padding (rows, columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Window {
    kernel: (usize, usize),
    stride: (usize, usize),
    dilation: (usize, usize),
    padding: Padding,
}

impl Window {
    /// The output's rows and columns over an input of `rows` x `columns`, if any.
    fn output(&self, rows: usize, columns: usize) -> Option<(usize, usize)> {
        let along =
            |size: usize, before: usize, after: usize, kernel: usize, stride: usize, dilation: usize| {
                let reach = dilation * (kernel - 1) + 1;
                let padded = size + before + after;
                (padded >= reach).then(|| (padded - reach) / stride + 1)
            };
        let p = self.padding;
        Some((
            along(
                rows,
                p.top,
                p.bottom,
                self.kernel.0,
                self.stride.0,
                self.dilation.0,
            )?,
            along(
                columns,
                p.left,
                p.right,
                self.kernel.1,
                self.stride.1,
                self.dilation.1,
            )?,
        ))
    }

    /// For tap offset `offset` (dilation times tap index, minus the leading padding) along an
    /// axis with `stride`, the outputs `lo..hi` (of `outputs`) whose input `o·stride +
    /// offset` falls inside `0..size`.
    fn span(offset: isize, stride: usize, size: usize, outputs: usize) -> (usize, usize) {
        let stride = stride as isize;
        // o * stride + offset >= 0  and  o * stride + offset <= size - 1
        let lo = if offset >= 0 {
            0
        } else {
            (-offset + stride - 1) / stride
        };
        let last = size as isize - 1 - offset;
        let hi = if last < 0 { 0 } else { last / stride + 1 };
        let hi = (hi as usize).min(outputs);
        ((lo as usize).min(hi), hi)
    }

    /// Calls `visit(tap, y, xs, first)` for every kernel tap (row-major) and every output
    /// row `y` of a plane of `to` that the tap reaches in a plane of `from`: outputs `xs` of
    /// that row read inside the input plane, the first of them at index `first` of the
    /// input plane, the next ones every `stride.1` after it.
    fn sweep(
        &self,
        from: Shape,
        to: Shape,
        mut visit: impl FnMut(usize, usize, std::ops::Range<usize>, usize),
    ) {
        for ky in 0..self.kernel.0 {
            let dy = (ky * self.dilation.0) as isize - self.padding.top as isize;
            let (y_lo, y_hi) = Window::span(dy, self.stride.0, from.rows, to.rows);
            for kx in 0..self.kernel.1 {
                let dx = (kx * self.dilation.1) as isize - self.padding.left as isize;
                let (x_lo, x_hi) = Window::span(dx, self.stride.1, from.columns, to.columns);
                if x_lo >= x_hi {
                    continue;
                }
                for y in y_lo..y_hi {
                    let iy = ((y * self.stride.0) as isize + dy) as usize;
                    let ix = ((x_lo * self.stride.1) as isize + dx) as usize;
                    visit(ky * self.kernel.1 + kx, y, x_lo..x_hi, iy * from.columns + ix);
                }
            }
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
struct Convolution {
    window: Window,
    groups: usize,
    /// Input channels each output channel reads.
    inputs_per_group: usize,
    /// `[out][in / groups][kernel rows][kernel columns]`.
    weight: Vec<f32>,
    bias: Vec<f32>,
}

#[derive(Debug, Clone, PartialEq)]
enum Layer {
    Convolution(Convolution),
    Relu,
    /// One slope per channel for the negative part.
    PRelu(Vec<f32>),
    Add,
    MaxPool(Window),
    /// Zeros added around each plane and channels added before and after.
    Pad {
        channels: (usize, usize),
        padding: Padding,
    },
    /// The same values under another shape.
    Reshape,
}

#[derive(Debug, Clone, PartialEq)]
struct Step {
    layer: Layer,
    inputs: Vec<usize>,
    output: usize,
    input_shape: Shape,
    shape: Shape,
}

/// A network ready to run on pictures of one shape.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvNet {
    input: Shape,
    steps: Vec<Step>,
    /// After which step each value is read for the last time (the input's is value 0).
    last_read: Vec<usize>,
    outputs: Vec<usize>,
    value_count: usize,
}

/// What building one node needs to know about the graph.
struct Builder<'a> {
    constants: &'a HashMap<String, Constant>,
    values: HashMap<String, (usize, Shape)>,
}

impl Builder<'_> {
    fn floats(&self, node: &Node, index: usize) -> Result<(&[usize], &[f32]), String> {
        match node.inputs.get(index).and_then(|name| self.constants.get(name)) {
            Some(Constant::Float { dims, values }) => Ok((dims, values)),
            _ => Err(format!("input {index} is not a constant float tensor")),
        }
    }

    fn int64s(&self, node: &Node, index: usize) -> Result<&[i64], String> {
        match node.inputs.get(index).and_then(|name| self.constants.get(name)) {
            Some(Constant::Int64 { values, .. }) => Ok(values),
            _ => Err(format!("input {index} is not a constant int64 tensor")),
        }
    }

    fn value(&self, node: &Node, index: usize) -> Result<(usize, Shape), String> {
        let name = node
            .inputs
            .get(index)
            .ok_or_else(|| format!("input {index} is missing"))?;
        self.values
            .get(name)
            .copied()
            .ok_or_else(|| format!("input `{name}` is no value computed before it"))
    }
}

/// A list of non-negative integers from an attribute, or `default` without it.
fn sizes(node: &Node, name: &str, default: &[usize], count: usize) -> Result<Vec<usize>, String> {
    let Some(values) = node.ints(name) else {
        return Ok(default.to_vec());
    };
    if values.len() != count {
        return Err(format!("`{name}` has {} values, not {count}", values.len()));
    }
    values
        .iter()
        .map(|&v| usize::try_from(v).map_err(|_| format!("`{name}` holds {v}")))
        .collect()
}

fn window(node: &Node, kernel: (usize, usize)) -> Result<Window, String> {
    let stride = sizes(node, "strides", &[1, 1], 2)?;
    let dilation = sizes(node, "dilations", &[1, 1], 2)?;
    let pads = sizes(node, "pads", &[0, 0, 0, 0], 4)?;
    if stride.contains(&0) || dilation.contains(&0) || kernel.0 == 0 || kernel.1 == 0 {
        return Err("a zero kernel, stride or dilation".into());
    }
    if node.string("auto_pad").is_some_and(|p| p != "NOTSET") {
        return Err("auto_pad (only explicit pads are read)".into());
    }
    Ok(Window {
        kernel,
        stride: (stride[0], stride[1]),
        dilation: (dilation[0], dilation[1]),
        padding: Padding {
            top: pads[0],
            left: pads[1],
            bottom: pads[2],
            right: pads[3],
        },
    })
}

fn convolution(builder: &Builder, node: &Node, input: Shape) -> Result<(Layer, Shape), String> {
    let (dims, weight) = builder.floats(node, 1)?;
    let &[outputs, inputs_per_group, kernel_rows, kernel_columns] = dims else {
        return Err(format!(
            "weight of dimensions {dims:?}, not [out, in, rows, columns]"
        ));
    };
    let groups = sizes(node, "group", &[1], 1)?[0];
    if groups == 0 || inputs_per_group * groups != input.channels || outputs % groups != 0 {
        return Err(format!(
            "{groups} groups of {inputs_per_group} input channels for {} channels and {outputs} outputs",
            input.channels
        ));
    }
    if let Some(kernel) = node.ints("kernel_shape") {
        if kernel != [kernel_rows as i64, kernel_columns as i64] {
            return Err(format!("kernel_shape {kernel:?} against a weight of {dims:?}"));
        }
    }
    let bias = match node.inputs.len() {
        2 => vec![0.0; outputs],
        _ => {
            let (bias_dims, bias) = builder.floats(node, 2)?;
            if bias_dims != [outputs] {
                return Err(format!("bias of dimensions {bias_dims:?} for {outputs} outputs"));
            }
            bias.to_vec()
        }
    };
    let window = window(node, (kernel_rows, kernel_columns))?;
    let (rows, columns) = window
        .output(input.rows, input.columns)
        .ok_or("the kernel is larger than the padded input")?;
    let layer = Layer::Convolution(Convolution {
        window,
        groups,
        inputs_per_group,
        weight: weight.to_vec(),
        bias,
    });
    Ok((
        layer,
        Shape {
            channels: outputs,
            rows,
            columns,
        },
    ))
}

fn max_pool(node: &Node, input: Shape) -> Result<(Layer, Shape), String> {
    let kernel = sizes(node, "kernel_shape", &[], 2)?;
    if node.ints("ceil_mode").is_some_and(|c| c != [0]) {
        return Err("ceil_mode (only floor is read)".into());
    }
    let window = window(node, (kernel[0], kernel[1]))?;
    let (rows, columns) = window
        .output(input.rows, input.columns)
        .ok_or("the window is larger than the padded input")?;
    Ok((
        Layer::MaxPool(window),
        Shape {
            rows,
            columns,
            ..input
        },
    ))
}

fn pad(builder: &Builder, node: &Node, input: Shape) -> Result<(Layer, Shape), String> {
    if node.string("mode").is_some_and(|m| m != "constant") {
        return Err("a mode other than constant".into());
    }
    if node.inputs.len() > 2 && !node.inputs[2].is_empty() {
        let (_, value) = builder.floats(node, 2)?;
        if value.iter().any(|&v| v != 0.0) {
            return Err("a constant other than zero".into());
        }
    }
    let pads = builder.int64s(node, 1)?;
    let pads: Vec<usize> = pads
        .iter()
        .map(|&p| usize::try_from(p).map_err(|_| format!("pads {pads:?}: negative")))
        .collect::<Result<_, _>>()?;
    let &[n0, c0, top, left, n1, c1, bottom, right] = pads.as_slice() else {
        return Err(format!("pads {pads:?}: not eight values for NCHW"));
    };
    if n0 != 0 || n1 != 0 {
        return Err("padding along N".into());
    }
    let shape = Shape {
        channels: input.channels + c0 + c1,
        rows: input.rows + top + bottom,
        columns: input.columns + left + right,
    };
    let padding = Padding {
        top,
        left,
        bottom,
        right,
    };
    Ok((
        Layer::Pad {
            channels: (c0, c1),
            padding,
        },
        shape,
    ))
}

fn reshape(builder: &Builder, node: &Node, input: Shape) -> Result<(Layer, Shape), String> {
    let dims = builder.int64s(node, 1)?;
    let len = input.len();
    let shape = match *dims {
        [1, n] if n == len as i64 || n == -1 => Shape {
            channels: len,
            rows: 1,
            columns: 1,
        },
        [1, c, h, w] if c * h * w == len as i64 && c > 0 && h > 0 && w > 0 => Shape {
            channels: c as usize,
            rows: h as usize,
            columns: w as usize,
        },
        _ => return Err(format!("shape {dims:?} for {len} values")),
    };
    Ok((Layer::Reshape, shape))
}

impl ConvNet {
    /// Builds the network of `graph` for an input `input` (named `input_name` in the
    /// graph) giving the values named `outputs`, each as a flat list.
    pub fn from_onnx(
        graph: &OnnxGraph,
        input_name: &str,
        input: Shape,
        outputs: &[&str],
    ) -> Result<ConvNet, NetError> {
        let mut builder = Builder {
            constants: &graph.constants,
            values: HashMap::from([(input_name.to_string(), (0, input))]),
        };
        let mut steps = Vec::with_capacity(graph.nodes.len());
        for node in &graph.nodes {
            let fail = |reason: String| NetError::Node {
                node: node.name.clone(),
                op: node.op.clone(),
                reason,
            };
            let (first, input_shape) = builder.value(node, 0).map_err(fail)?;
            let mut inputs = vec![first];
            let (layer, shape) = match node.op.as_str() {
                "Conv" => convolution(&builder, node, input_shape),
                "Relu" => Ok((Layer::Relu, input_shape)),
                "PRelu" => builder.floats(node, 1).and_then(|(_, slope)| {
                    if slope.len() == input_shape.channels {
                        Ok((Layer::PRelu(slope.to_vec()), input_shape))
                    } else {
                        Err(format!(
                            "{} slopes for {} channels",
                            slope.len(),
                            input_shape.channels
                        ))
                    }
                }),
                "Add" => builder.value(node, 1).and_then(|(second, shape)| {
                    inputs.push(second);
                    if shape == input_shape {
                        Ok((Layer::Add, input_shape))
                    } else {
                        Err(format!("adds {shape:?} to {input_shape:?}"))
                    }
                }),
                "MaxPool" => max_pool(node, input_shape),
                "Pad" => pad(&builder, node, input_shape),
                "Reshape" => reshape(&builder, node, input_shape),
                other => Err(format!("operator {other} is not one this reader runs")),
            }
            .map_err(fail)?;
            let [name] = node.outputs.as_slice() else {
                return Err(fail(format!("{} outputs, not one", node.outputs.len())));
            };
            let output = steps.len() + 1;
            builder.values.insert(name.clone(), (output, shape));
            steps.push(Step {
                layer,
                inputs,
                output,
                input_shape,
                shape,
            });
        }
        let outputs = outputs
            .iter()
            .map(|&name| {
                builder
                    .values
                    .get(name)
                    .map(|&(value, _)| value)
                    .ok_or_else(|| NetError::Output(name.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let value_count = steps.len() + 1;
        let mut last_read = vec![0; value_count];
        for (k, step) in steps.iter().enumerate() {
            for &value in &step.inputs {
                last_read[value] = k;
            }
        }
        for &value in &outputs {
            last_read[value] = usize::MAX;
        }
        Ok(ConvNet {
            input,
            steps,
            last_read,
            outputs,
            value_count,
        })
    }

    /// Runs the network on `input` (channel planes, rows top first): the outputs asked for
    /// when it was built, in that order.
    pub fn run(&self, input: &[f32]) -> Result<Vec<Vec<f32>>, NetError> {
        if input.len() != self.input.len() {
            return Err(NetError::Input {
                expected: self.input.len(),
                found: input.len(),
            });
        }
        let mut values: Vec<Option<Vec<f32>>> = vec![None; self.value_count];
        values[0] = Some(input.to_vec());
        for (k, step) in self.steps.iter().enumerate() {
            // An elementwise step writes over its first input where nothing reads it later.
            let owned = |values: &mut [Option<Vec<f32>>]| {
                let value = step.inputs[0];
                let shared = self.last_read[value] != k || step.inputs[1..].contains(&value);
                match shared {
                    true => values[value].clone(),
                    false => values[value].take(),
                }
                .expect("computed before")
            };
            let out = match &step.layer {
                Layer::Relu => {
                    let mut out = owned(&mut values);
                    out.iter_mut().for_each(|v| *v = v.max(0.0));
                    out
                }
                Layer::PRelu(slopes) => {
                    let mut out = owned(&mut values);
                    prelu(slopes, &mut out, step.shape.plane());
                    out
                }
                Layer::Add => {
                    let mut out = owned(&mut values);
                    let second = values[step.inputs[1]].as_deref().expect("computed before");
                    out.iter_mut().zip(second).for_each(|(a, b)| *a += b);
                    out
                }
                Layer::Reshape => owned(&mut values),
                layer => {
                    let first = values[step.inputs[0]].as_deref().expect("computed before");
                    let (from, to) = (step.input_shape, step.shape);
                    match layer {
                        Layer::Convolution(c) => convolve(c, first, from, to),
                        Layer::MaxPool(window) => max_pool_planes(window, first, from, to),
                        Layer::Pad { channels, padding } => pad_planes(channels.0, *padding, first, from, to),
                        _ => unreachable!("elementwise steps are above"),
                    }
                }
            };
            values[step.output] = Some(out);
            for &value in &step.inputs {
                if self.last_read[value] == k {
                    values[value] = None;
                }
            }
        }
        Ok(self
            .outputs
            .iter()
            .map(|&value| values[value].clone().expect("an output is kept"))
            .collect())
    }
}

fn convolve(c: &Convolution, input: &[f32], from: Shape, to: Shape) -> Vec<f32> {
    let mut out = vec![0.0; to.len()];
    let w = c.window;
    if c.groups == 1 {
        // Without groups a convolution is one product: the weights (out x in·taps) times
        // the input's taps gathered column by column (in·taps x output pixels), which for a
        // 1 x 1 kernel are the input's planes themselves.
        let taps = w.kernel.0 * w.kernel.1;
        let rows = from.channels * taps;
        let gathered;
        let columns = if taps == 1 && w.stride == (1, 1) && from.plane() == to.plane() {
            input
        } else {
            gathered = gather_taps(&w, input, from, to);
            &gathered
        };
        let weights = faer::MatRef::from_row_major_slice(&c.weight, to.channels, rows);
        let columns = faer::MatRef::from_row_major_slice(columns, rows, to.plane());
        for (plane, &bias) in out.chunks_exact_mut(to.plane()).zip(&c.bias) {
            plane.fill(bias);
        }
        let result = faer::MatMut::from_row_major_slice_mut(&mut out, to.channels, to.plane());
        faer::linalg::matmul::matmul(result, faer::Accum::Add, weights, columns, 1.0, faer::Par::Seq);
        return out;
    }
    let outputs_per_group = to.channels / c.groups;
    let taps = w.kernel.0 * w.kernel.1;
    out.par_chunks_mut(to.plane()).enumerate().for_each(|(o, plane)| {
        plane.fill(c.bias[o]);
        let group = o / outputs_per_group;
        for j in 0..c.inputs_per_group {
            let channel = group * c.inputs_per_group + j;
            let source = &input[channel * from.plane()..][..from.plane()];
            let weights = &c.weight[(o * c.inputs_per_group + j) * taps..][..taps];
            w.sweep(from, to, |tap, y, xs, first| {
                let weight = weights[tap];
                let target = &mut plane[y * to.columns..][xs];
                if w.stride.1 == 1 {
                    for (t, &s) in target.iter_mut().zip(&source[first..]) {
                        *t += weight * s;
                    }
                } else {
                    for (t, &s) in target.iter_mut().zip(source[first..].iter().step_by(w.stride.1)) {
                        *t += weight * s;
                    }
                }
            });
        }
    });
    out
}

/// Every kernel tap's input value for every output pixel: row `(channel, ky, kx)`, column
/// `(y, x)`, zero where the tap falls in the padding.
fn gather_taps(w: &Window, input: &[f32], from: Shape, to: Shape) -> Vec<f32> {
    let taps = w.kernel.0 * w.kernel.1;
    let mut columns = vec![0.0; from.channels * taps * to.plane()];
    for (channel, source) in input.chunks_exact(from.plane()).enumerate() {
        w.sweep(from, to, |tap, y, xs, first| {
            let row = (channel * taps + tap) * to.plane() + y * to.columns;
            let target = &mut columns[row..][xs];
            for (t, &s) in target.iter_mut().zip(source[first..].iter().step_by(w.stride.1)) {
                *t = s;
            }
        });
    }
    columns
}

/// Scales each channel's negative values by its slope.
fn prelu(slopes: &[f32], values: &mut [f32], plane: usize) {
    for (channel, &slope) in values.chunks_exact_mut(plane).zip(slopes) {
        for v in channel {
            *v = if *v < 0.0 { *v * slope } else { *v };
        }
    }
}

fn max_pool_planes(w: &Window, input: &[f32], from: Shape, to: Shape) -> Vec<f32> {
    let mut out = vec![f32::NEG_INFINITY; to.len()];
    for (source, plane) in input
        .chunks_exact(from.plane())
        .zip(out.chunks_exact_mut(to.plane()))
    {
        w.sweep(from, to, |_, y, xs, first| {
            let target = &mut plane[y * to.columns..][xs];
            for (t, &s) in target.iter_mut().zip(source[first..].iter().step_by(w.stride.1)) {
                *t = t.max(s);
            }
        });
    }
    out
}

fn pad_planes(channels_before: usize, p: Padding, input: &[f32], from: Shape, to: Shape) -> Vec<f32> {
    let mut out = vec![0.0; to.len()];
    for (c, source) in input.chunks_exact(from.plane()).enumerate() {
        let plane = &mut out[(c + channels_before) * to.plane()..][..to.plane()];
        for (y, row) in source.chunks_exact(from.columns).enumerate() {
            plane[(y + p.top) * to.columns + p.left..][..from.columns].copy_from_slice(row);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(op: &str, inputs: &[&str], output: &str, ints: &[(&str, &[i64])]) -> Node {
        Node::new(
            op,
            op,
            inputs.iter().map(|s| s.to_string()).collect(),
            vec![output.to_string()],
            ints.iter().map(|(k, v)| (k.to_string(), v.to_vec())).collect(),
        )
    }

    fn floats(dims: &[usize], values: &[f32]) -> Constant {
        Constant::Float {
            dims: dims.to_vec(),
            values: values.to_vec(),
        }
    }

    fn shape(channels: usize, rows: usize, columns: usize) -> Shape {
        Shape {
            channels,
            rows,
            columns,
        }
    }

    fn run_one(n: Node, constants: &[(&str, Constant)], input: Shape, values: &[f32]) -> Vec<f32> {
        let graph = OnnxGraph {
            nodes: vec![n],
            constants: constants
                .iter()
                .map(|(k, v)| (k.to_string(), v.clone()))
                .collect(),
        };
        let net = ConvNet::from_onnx(&graph, "x", input, &["y"]).unwrap();
        net.run(values).unwrap().remove(0)
    }

    #[test]
    fn a_padded_strided_convolution_is_hand_computable() {
        // One 3 x 3 plane 1..9, a 2 x 2 kernel [[1, 0], [0, 2]] and bias 0.5, stride 2,
        // one row and column of zeros before: out(y, x) = 0.5 + in(2y-1, 2x-1) + 2 in(2y, 2x).
        let n = node(
            "Conv",
            &["x", "w", "b"],
            "y",
            &[("strides", &[2, 2]), ("pads", &[1, 1, 0, 0])],
        );
        let y = run_one(
            n,
            &[
                ("w", floats(&[1, 1, 2, 2], &[1.0, 0.0, 0.0, 2.0])),
                ("b", floats(&[1], &[0.5])),
            ],
            shape(1, 3, 3),
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
        );
        // (0,0): 0.5 + 0 + 2*1; (0,1): 0.5 + 0 + 2*3; (1,0): 0.5 + 0 + 2*7; (1,1): 0.5 + 5 + 2*9.
        assert_eq!(y, vec![2.5, 6.5, 14.5, 23.5]);
    }

    #[test]
    fn a_depthwise_dilated_convolution_keeps_channels_apart() {
        // Two channels, each with its own 1 x 2 kernel dilated by 2 along x, no padding.
        let n = node(
            "Conv",
            &["x", "w"],
            "y",
            &[("group", &[2]), ("dilations", &[1, 2])],
        );
        let y = run_one(
            n,
            &[("w", floats(&[2, 1, 1, 2], &[1.0, 10.0, -1.0, 1.0]))],
            shape(2, 1, 3),
            &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        );
        assert_eq!(y, vec![1.0 + 30.0, -4.0 + 6.0]);
    }

    #[test]
    fn pooling_padding_and_activations_are_hand_computable() {
        let pool = node(
            "MaxPool",
            &["x"],
            "y",
            &[
                ("kernel_shape", &[2, 2]),
                ("strides", &[2, 2]),
                ("pads", &[0, 0, 1, 1]),
            ],
        );
        let y = run_one(
            pool,
            &[],
            shape(1, 3, 3),
            &[1.0, -2.0, 3.0, 4.0, 5.0, -6.0, -7.0, 8.0, -9.0],
        );
        // Padded cells never win, even over negatives.
        assert_eq!(y, vec![5.0, 3.0, 8.0, -9.0]);

        let pads = Constant::Int64 {
            dims: vec![8],
            values: vec![0, 1, 0, 1, 0, 0, 1, 0],
        };
        let y = run_one(
            node("Pad", &["x", "p"], "y", &[]),
            &[("p", pads)],
            shape(1, 1, 2),
            &[1.0, 2.0],
        );
        // A zero channel before, a zero column before and a zero row after.
        assert_eq!(
            y,
            vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0]
        );

        let slope = floats(&[2, 1, 1], &[0.5, 0.25]);
        let y = run_one(
            node("PRelu", &["x", "s"], "y", &[]),
            &[("s", slope)],
            shape(2, 1, 2),
            &[-2.0, 2.0, -4.0, 4.0],
        );
        assert_eq!(y, vec![-1.0, 2.0, -1.0, 4.0]);
    }

    #[test]
    fn what_the_reader_cannot_run_is_named() {
        let graph = OnnxGraph {
            nodes: vec![node("Softmax", &["x"], "y", &[])],
            constants: HashMap::new(),
        };
        let error = ConvNet::from_onnx(&graph, "x", shape(1, 2, 2), &["y"]).unwrap_err();
        assert_eq!(
            error.to_string(),
            "node `Softmax` (Softmax): operator Softmax is not one this reader runs"
        );
        let graph = OnnxGraph {
            nodes: vec![node("Relu", &["x"], "y", &[])],
            constants: HashMap::new(),
        };
        let net = ConvNet::from_onnx(&graph, "x", shape(1, 2, 2), &["y"]).unwrap();
        assert_eq!(
            net.run(&[1.0]).unwrap_err(),
            NetError::Input {
                expected: 4,
                found: 1
            }
        );
        assert_eq!(
            ConvNet::from_onnx(&graph, "x", shape(1, 2, 2), &["z"]).unwrap_err(),
            NetError::Output("z".into())
        );
    }
}
