//! URDF reading (SPEC-spatial S2): URDF **text** → a serial [`Chain`] from a named base link to a
//! named tool link. The library does no file I/O; the CLI reads the file and passes the text.
//!
//! ```text
//! text ──Urdf::parse──▶ Urdf (links, joints, tree) ──Urdf::chain(base, tool)──▶ (Chain, warnings)
//! ```
//!
//! # What is read (the URDF XML specification, ref. 1)
//!
//! - `<robot name>` and its direct `<link>` and `<joint>` children. Everything else — `<visual>`,
//!   `<collision>`, `<material>`, `<transmission>` (whose nested `<joint>` elements are not
//!   joints of the tree), `<gazebo>`, comments, unknown elements and attributes — is ignored.
//! - `<origin xyz rpy>` (defaults zero). URDF `rpy` is fixed-axis roll–pitch–yaw: the rotation of
//!   the child frame in the parent frame is `R = Rz(yaw) · Ry(pitch) · Rx(roll)`, and the origin is
//!   `X_PC = (R, xyz)`.
//! - `<axis xyz>` in the joint frame, default `(1, 0, 0)`, normalised; a zero axis on a movable
//!   joint is an error.
//! - `<limit lower upper effort velocity>`: required on `revolute` and `prismatic` joints (as the
//!   URDF spec says; `lower`/`upper` default to 0, a missing `effort`/`velocity` is read as +∞);
//!   `continuous` joints have infinite position limits. `<dynamics damping>` (default 0).
//! - `<inertial><origin/><mass value/><inertia ixx ixy ixz iyy iyz izz/></inertial>`: the
//!   `<origin>` is the frame `C` of the centre of mass in the link frame `L`; the inertia tensor is
//!   about the centre of mass in `C`'s axes, so in link axes it is `I_L = R_LC I_C R_LCᵀ` and the
//!   centre of mass is `p_LC`. Missing inertia entries are 0; a link without `<inertial>` is
//!   massless.
//! - Numbers are `f64`; an unparsable or non-finite number is an error naming the element, the
//!   attribute and the line, and so are magnitudes no robot has (they would overflow the
//!   dynamics): an `<origin xyz>` entry or a prismatic limit beyond [`MAX_LENGTH`] (1 km), a
//!   mass or inertia entry beyond [`MAX_LINK_MASS`]. A `<!DOCTYPE>` is refused on its line.
//!
//! # From the tree to the chain
//!
//! The path is found by walking up from the tool link through parent joints until the base link
//! (if the walk reaches the root first, the base is not an ancestor of the tool: an error naming
//! both). Along the path:
//!
//! - `revolute` and `continuous` joints become [`JointKind::Revolute`], `prismatic`
//!   [`JointKind::Prismatic`]; `floating` and `planar` joints on the path are errors, and so is a
//!   `<mimic>` joint.
//! - Fixed joints are merged **exactly**: the links they attach become part of the rigid body of
//!   the preceding movable joint (mass summed, centre of mass the mass-weighted mean, rotational
//!   inertia about the combined centre of mass by the parallel-axis theorem after rotating each
//!   part's tensor into the body axes: `I = Σ_i R_i I_i R_iᵀ + m_i (|d_i|² 𝟙 − d_i d_iᵀ)` with
//!   `d_i = c_i − c`). Their origins compose into the next movable joint's placement
//!   ([`ChainJoint::placement`]) or, after the last movable joint, into [`Chain::tool`]. Fixed
//!   joints between the base link and the first movable joint compose into the first joint's
//!   placement; their links' mass belongs to the base and is not part of the chain.
//! - Subtrees that branch off the path at a moving body (a camera, a gripper, links beyond the
//!   tool link) are carried by that body: links attached by fixed joints are merged as above. A
//!   **movable** joint off the path (e.g. gripper fingers) is welded at `q = 0` and merged the
//!   same way, with a warning naming the joint. Branches off the base side (before the first
//!   movable joint, e.g. a second arm) are not part of the chain and are ignored silently.
//! - Every moving body must have mass > 0 and a positive-definite inertia after merging (errors
//!   naming the link and the URDF line); massless fixed links (`tool0`, `ee_link`, `flange`) are
//!   normal. Then [`Chain::validate`] runs; its warnings (an inertia that breaks the triangle
//!   inequality) are returned.
//! - A link with two parent joints (a closed loop, which URDF cannot express) and a cycle of
//!   joints are errors when the text is parsed, wherever they are.
//!
//! # Embedded models
//!
//! [`UR5_URDF`] ([`ur5`]: `base_link` → `tool0`, 6 DOF) and [`FRANKA_URDF`] ([`franka`]:
//! `panda_link0` → `panda_link8`, 7 DOF) are written from the manufacturers' published kinematic
//! tables and published inertial parameters (refs. 2–4); each file's header comment cites the source of
//! every block. Both load without warnings.
//!
//! # References
//!
//! 1. ROS, "urdf/XML" (the URDF XML specification: `link`, `joint`, `inertial`, `origin`).
//! 2. Universal Robots, "DH parameters for calculations of kinematics and dynamics" (UR5).
//! 3. Franka Emika, "Robot and interface specifications: control parameters" (Panda DH, limits).
//! 4. C. Gaz, M. Cognetti, A. Oliva, P. Robuffo Giordano, A. De Luca, "Dynamic Identification of
//!    the Franka Emika Panda Robot With Retrieval of Feasible Parameters Using Penalty-Based
//!    Optimization", IEEE RA-L 4(4), 2019.

use std::collections::HashMap;

use nalgebra::{Isometry3, Matrix3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use roxmltree::{Document, Node};
use thiserror::Error;

use super::chain::{Chain, ChainJoint, JointKind, JointLimits, RigidBody};
use crate::error::ModelError;

/// The embedded UR5-class model (`models/ur5.urdf`, sources cited in the file): Universal
/// Robots' DH kinematics, published masses and centres of mass, cylinder inertias. Base
/// [`UR5_BASE`], tool [`UR5_TOOL`].
pub const UR5_URDF: &str = include_str!("../../../models/ur5.urdf");
/// Base link of [`UR5_URDF`] (ur_description's `base_link`: the DH base frame turned by π about z).
pub const UR5_BASE: &str = "base_link";
/// Tool link of [`UR5_URDF`] (`tool0`: DH frame 6, z out of the flange).
pub const UR5_TOOL: &str = "tool0";

/// The embedded Franka-class (Panda, no hand) model (`models/franka.urdf`, sources cited in the
/// file): Franka's modified-DH kinematics and limits, Gaz et al. (2019) inertial parameters. Base
/// [`FRANKA_BASE`], tool [`FRANKA_TOOL`]; a massless `panda_hand_tcp` frame is also there.
pub const FRANKA_URDF: &str = include_str!("../../../models/franka.urdf");
/// Base link of [`FRANKA_URDF`].
pub const FRANKA_BASE: &str = "panda_link0";
/// Tool link of [`FRANKA_URDF`] (`panda_link8`: the flange, Craig frame 8).
pub const FRANKA_TOOL: &str = "panda_link8";
/// The joint torque-rate limit of a Franka arm, N m/s, every joint: the Franka Control
/// Interface's `τ̇_j,max = 1000` N m/s ("Robot and interface specifications", limits for
/// Panda and for Franka Research 3, <https://frankaemika.github.io/docs/control_parameters.html>;
/// a command changing faster aborts the motion with `controller_torque_discontinuity`). The
/// default `rate_limit` of the actuator stage for a scenario with a Franka arm (issue 24).
/// Universal Robots publish no torque-rate figure for the UR5 (searched: user manual and
/// datasheet, the ROS driver's docs), so the UR5 model has no default.
pub const FRANKA_TORQUE_RATE_LIMIT: f64 = 1000.0;

/// The UR5-class chain [`UR5_BASE`] → [`UR5_TOOL`] from [`UR5_URDF`] (6 revolute joints; no
/// warnings).
pub fn ur5() -> Chain {
    load_chain(UR5_URDF, UR5_BASE, UR5_TOOL)
        .expect("the embedded UR5 model loads (tested)")
        .0
}

/// The Franka-class chain [`FRANKA_BASE`] → [`FRANKA_TOOL`] from [`FRANKA_URDF`] (7 revolute
/// joints; no warnings: the Gaz et al. inertias satisfy the triangle inequality).
pub fn franka() -> Chain {
    load_chain(FRANKA_URDF, FRANKA_BASE, FRANKA_TOOL)
        .expect("the embedded Franka model loads (tested)")
        .0
}

/// An error while reading URDF text or extracting a chain from it. Each variant names the element
/// (link, joint, attribute) and, where it comes from the text, its 1-based URDF line.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum UrdfError {
    /// The text is not well-formed XML.
    #[error("URDF line {line}, column {col}: malformed XML: {msg}")]
    Xml {
        /// 1-based line.
        line: u32,
        /// 1-based column.
        col: u32,
        /// The XML parser's message.
        msg: String,
    },
    /// The text has a document type declaration (`<!DOCTYPE ...>`): URDF has no DTD, and one is
    /// not read (its entities could expand a small file into gigabytes).
    #[error(
        "URDF line {line}, column {col}: <!DOCTYPE ...>: a DTD is not accepted in a URDF file; delete the DOCTYPE declaration"
    )]
    Dtd {
        /// 1-based line of the `<!DOCTYPE`.
        line: u32,
        /// 1-based column (in characters) of the `<!DOCTYPE`.
        col: u32,
    },
    /// The root element is not `<robot>`.
    #[error("URDF line {line}: the root element is <{found}>, a URDF needs <robot>")]
    NotARobot {
        /// The root element's tag.
        found: String,
        /// Its line.
        line: u32,
    },
    /// A required element is absent.
    #[error("URDF line {line}: {owner} has no <{element}> element, which the URDF spec requires")]
    MissingElement {
        /// The element that should contain it, e.g. `joint elbow`.
        owner: String,
        /// The missing element's tag.
        element: String,
        /// The owner's line.
        line: u32,
    },
    /// A required attribute is absent.
    #[error("URDF line {line}: {owner}: <{element}> has no `{attr}` attribute")]
    MissingAttribute {
        /// The link or joint it belongs to, e.g. `joint elbow` (or `robot`).
        owner: String,
        /// The element's tag.
        element: String,
        /// The attribute.
        attr: String,
        /// The element's line.
        line: u32,
    },
    /// An attribute whose value cannot be used (not a number, not finite, wrong count, out of
    /// range, unknown joint type, ...).
    #[error("URDF line {line}: {owner}: <{element} {attr}=\"{}\">: {reason}", excerpt(.value))]
    BadAttribute {
        /// The link or joint it belongs to, e.g. `link forearm` (or `robot`).
        owner: String,
        /// The element's tag.
        element: String,
        /// The attribute.
        attr: String,
        /// Its value as written.
        value: String,
        /// The attribute's line.
        line: u32,
        /// Why it cannot be used.
        reason: String,
    },
    /// Two links or two joints share a name.
    #[error("URDF line {line}: a second {kind} named `{}` (the first is at line {first_line})", name_excerpt(.name))]
    Duplicate {
        /// `link` or `joint`.
        kind: String,
        /// The shared name.
        name: String,
        /// The second one's line.
        line: u32,
        /// The first one's line.
        first_line: u32,
    },
    /// A joint names a parent or child link that does not exist.
    #[error("URDF line {line}: joint {}: its {role} link `{}` does not exist{}", name_excerpt(.joint), name_excerpt(.link), did_you_mean(.suggestion))]
    UnknownLink {
        /// The joint.
        joint: String,
        /// `parent` or `child`.
        role: String,
        /// The link name as written.
        link: String,
        /// The joint's line.
        line: u32,
        /// The nearest existing link name.
        suggestion: Option<String>,
    },
    /// The requested base or tool link does not exist.
    #[error("no link named `{}` in the URDF{}", name_excerpt(.name), did_you_mean(.suggestion))]
    MissingLink {
        /// The name asked for.
        name: String,
        /// The nearest existing link name.
        suggestion: Option<String>,
    },
    /// A link is the child of two joints (a closed loop inside one URDF).
    #[error(
        "URDF line {line}: link {link} has two parent joints, {first} (line {first_line}) and {second}: a closed loop, which a URDF tree cannot hold"
    )]
    TwoParents {
        /// The link.
        link: String,
        /// The first parent joint.
        first: String,
        /// Its line.
        first_line: u32,
        /// The second parent joint.
        second: String,
        /// Its line.
        line: u32,
    },
    /// The joints form a cycle (every link on it has one parent, yet there is no root).
    #[error("URDF line {line}: link {link} is on a cycle of joints: a URDF must be a tree")]
    Cycle {
        /// A link on the cycle.
        link: String,
        /// Its line.
        line: u32,
    },
    /// The base and tool are not connected by a serial path from base to tool, or the path has no
    /// movable joint.
    #[error("not a chain from base {base} to tool {tool}: {reason}")]
    NotAChain {
        /// The base link asked for.
        base: String,
        /// The tool link asked for.
        tool: String,
        /// What is wrong.
        reason: String,
    },
    /// A `<mimic>` joint on the chain.
    #[error(
        "URDF line {line}: joint {joint} on the chain is a mimic joint, which is not supported"
    )]
    Mimic {
        /// The joint.
        joint: String,
        /// The `<mimic>` element's line.
        line: u32,
    },
    /// A `floating` or `planar` joint on the chain.
    #[error(
        "URDF line {line}: joint {joint} on the chain is `{kind}`: only revolute, continuous, prismatic and fixed joints are supported"
    )]
    UnsupportedJoint {
        /// The joint.
        joint: String,
        /// Its URDF type.
        kind: String,
        /// Its line.
        line: u32,
    },
    /// A movable joint whose `<axis xyz>` is the zero vector.
    #[error("URDF line {line}: joint {joint}: <axis xyz> is the zero vector")]
    ZeroAxis {
        /// The joint.
        joint: String,
        /// The `<axis>` line.
        line: u32,
    },
    /// A negative mass anywhere, or a moving body whose mass (after merging) is not > 0.
    #[error("URDF line {line}: link {link}: mass {} kg: {reason}", short(*.value))]
    BadMass {
        /// The link (for a moving body: the link that carries its frame).
        link: String,
        /// The mass, kg.
        value: f64,
        /// The `<mass>` line (or the `<link>` line when it has none).
        line: u32,
        /// Why it is wrong.
        reason: String,
    },
    /// A moving body whose inertia (after merging) is not positive definite.
    #[error("URDF line {line}: link {link}: {reason}")]
    BadInertia {
        /// The link that carries the body's frame.
        link: String,
        /// The `<inertia>` line (or the `<link>` line when it has none).
        line: u32,
        /// Why it is wrong (with the principal moments).
        reason: String,
    },
    /// The chain failed [`Chain::validate`] for a reason not caught above.
    #[error("URDF chain: {0}")]
    Model(#[from] ModelError),
}

fn did_you_mean(s: &Option<String>) -> String {
    match s {
        Some(n) => format!(" (did you mean `{n}`?)"),
        None => String::new(),
    }
}

impl UrdfError {
    /// The URDF line the error points at, when it comes from the text.
    pub fn line(&self) -> Option<u32> {
        use UrdfError::*;
        match self {
            Xml { line, .. }
            | Dtd { line, .. }
            | NotARobot { line, .. }
            | MissingElement { line, .. }
            | MissingAttribute { line, .. }
            | BadAttribute { line, .. }
            | Duplicate { line, .. }
            | UnknownLink { line, .. }
            | TwoParents { line, .. }
            | Cycle { line, .. }
            | Mimic { line, .. }
            | UnsupportedJoint { line, .. }
            | ZeroAxis { line, .. }
            | BadMass { line, .. }
            | BadInertia { line, .. } => Some(*line),
            MissingLink { .. } | NotAChain { .. } | Model(_) => None,
        }
    }
}

impl From<UrdfError> for ModelError {
    fn from(e: UrdfError) -> Self {
        match e {
            UrdfError::Model(m) => m,
            other => ModelError::geometry("URDF", other.to_string()),
        }
    }
}

/// The URDF joint types.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum UrdfKind {
    Revolute,
    Continuous,
    Prismatic,
    Fixed,
    Floating,
    Planar,
}

impl UrdfKind {
    fn name(self) -> &'static str {
        match self {
            UrdfKind::Revolute => "revolute",
            UrdfKind::Continuous => "continuous",
            UrdfKind::Prismatic => "prismatic",
            UrdfKind::Fixed => "fixed",
            UrdfKind::Floating => "floating",
            UrdfKind::Planar => "planar",
        }
    }
    fn movable_1dof(self) -> bool {
        matches!(
            self,
            UrdfKind::Revolute | UrdfKind::Continuous | UrdfKind::Prismatic
        )
    }
}

/// `<inertial>` of one link, in the link frame.
#[derive(Clone, Debug)]
struct Inertial {
    mass: f64,
    /// Centre of mass in the link frame, m.
    com: Vector3<f64>,
    /// About the centre of mass, link axes, kg m².
    inertia: Matrix3<f64>,
    mass_line: u32,
    inertia_line: u32,
}

#[derive(Clone, Debug)]
struct Link {
    name: String,
    line: u32,
    inertial: Option<Inertial>,
}

#[derive(Clone, Debug)]
struct Joint {
    name: String,
    line: u32,
    kind: UrdfKind,
    parent: usize,
    child: usize,
    /// `X_PJ`: the joint frame (= the child link frame at q = 0) in the parent link frame.
    origin: Isometry3<f64>,
    axis: Unit<Vector3<f64>>,
    limits: JointLimits,
    /// Line of `<limit>` (the joint's line when absent).
    limit_line: u32,
    damping: f64,
    /// Line of `<mimic>`, when present.
    mimic: Option<u32>,
}

/// A parsed URDF: its links and joints as a tree (each link has at most one parent joint).
#[derive(Clone, Debug)]
pub struct Urdf {
    name: String,
    links: Vec<Link>,
    joints: Vec<Joint>,
    link_index: HashMap<String, usize>,
    /// Parent joint of each link.
    parent_joint: Vec<Option<usize>>,
    /// Child joints of each link, in file order.
    child_joints: Vec<Vec<usize>>,
}

/// Parse `text` and extract the chain from `base` to `tool` ([`Urdf::parse`] then
/// [`Urdf::chain`]). Returns the chain and its warnings.
pub fn load_chain(text: &str, base: &str, tool: &str) -> Result<(Chain, Vec<String>), UrdfError> {
    Urdf::parse(text)?.chain(base, tool)
}

/// Reading context: byte offsets of the line starts, for line numbers in O(log n) (roxmltree's
/// `text_pos_at` scans from the start of the text on every call).
struct Ctx {
    line_starts: Vec<usize>,
}

impl Ctx {
    fn new(text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Ctx { line_starts }
    }

    /// 1-based line of byte offset `pos`.
    fn line_at(&self, pos: usize) -> u32 {
        let k = self.line_starts.partition_point(|&s| s <= pos);
        u32::try_from(k).unwrap_or(u32::MAX)
    }

    fn line(&self, node: Node) -> u32 {
        self.line_at(node.range().start)
    }

    fn attr_line(&self, node: Node, attr: &str) -> u32 {
        match node.attribute_node(attr) {
            Some(a) => self.line_at(a.range().start),
            None => self.line(node),
        }
    }

    fn required_attr<'n, 'i>(
        &self,
        node: Node<'n, 'i>,
        attr: &str,
        owner: &str,
    ) -> Result<&'n str, UrdfError> {
        node.attribute(attr)
            .ok_or_else(|| UrdfError::MissingAttribute {
                owner: owner.to_string(),
                element: node.tag_name().name().to_string(),
                attr: attr.to_string(),
                line: self.line(node),
            })
    }

    fn bad(&self, node: Node, attr: &str, owner: &str, value: &str, reason: &str) -> UrdfError {
        UrdfError::BadAttribute {
            owner: owner.to_string(),
            element: node.tag_name().name().to_string(),
            attr: attr.to_string(),
            value: value.to_string(),
            line: self.attr_line(node, attr),
            reason: reason.to_string(),
        }
    }

    /// Parse `N` finite numbers from attribute `attr` of `node`, or `default` when absent.
    fn numbers<const N: usize>(
        &self,
        node: Node,
        attr: &str,
        owner: &str,
        default: Option<[f64; N]>,
    ) -> Result<[f64; N], UrdfError> {
        let Some(text) = node.attribute(attr) else {
            return default.ok_or_else(|| UrdfError::MissingAttribute {
                owner: owner.to_string(),
                element: node.tag_name().name().to_string(),
                attr: attr.to_string(),
                line: self.line(node),
            });
        };
        let mut out = [0.0; N];
        let mut count = 0;
        for word in text.split_whitespace() {
            if count == N {
                count += 1;
                break;
            }
            let v: f64 = word.parse().map_err(|_| {
                self.bad(
                    node,
                    attr,
                    owner,
                    text,
                    &format!("`{}` is not a number", excerpt(word)),
                )
            })?;
            if !v.is_finite() {
                return Err(self.bad(node, attr, owner, text, "numbers must be finite"));
            }
            out[count] = v;
            count += 1;
        }
        if count != N {
            let reason = if N == 1 {
                "expected one number".to_string()
            } else {
                format!("expected {N} numbers")
            };
            return Err(self.bad(node, attr, owner, text, &reason));
        }
        Ok(out)
    }

    fn number(
        &self,
        node: Node,
        attr: &str,
        owner: &str,
        default: Option<f64>,
    ) -> Result<f64, UrdfError> {
        Ok(self.numbers::<1>(node, attr, owner, default.map(|d| [d]))?[0])
    }

    /// `<origin xyz rpy>` → `X_PC`; identity when the element is absent.
    fn origin(&self, node: Option<Node>, owner: &str) -> Result<Isometry3<f64>, UrdfError> {
        let Some(node) = node else {
            return Ok(Isometry3::identity());
        };
        let xyz = self.numbers::<3>(node, "xyz", owner, Some([0.0; 3]))?;
        if xyz.iter().any(|v| v.abs() > MAX_LENGTH) {
            return Err(self.bad(
                node,
                "xyz",
                owner,
                node.attribute("xyz").unwrap_or(""),
                &format!(
                    "an offset beyond {MAX_LENGTH:e} m: no robot's frames are that far apart; \
                     check the exponent and the unit"
                ),
            ));
        }
        let rpy = self.numbers::<3>(node, "rpy", owner, Some([0.0; 3]))?;
        Ok(Isometry3::from_parts(
            Translation3::new(xyz[0], xyz[1], xyz[2]),
            rpy_to_rotation(rpy),
        ))
    }
}

/// URDF fixed-axis roll–pitch–yaw: `R = Rz(yaw) · Ry(pitch) · Rx(roll)`.
pub fn rpy_to_rotation(rpy: [f64; 3]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rpy[2])
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), rpy[1])
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), rpy[0])
}

/// Byte offset of the `<!DOCTYPE` where an XML parser meets it: in the prolog, after a byte
/// order mark, the XML declaration, comments, processing instructions and white space (a
/// `<!DOCTYPE` inside a comment before it is not the one). `None` if the prolog holds none.
fn doctype_offset(text: &str) -> Option<usize> {
    let mut i = if text.starts_with('\u{feff}') { 3 } else { 0 };
    loop {
        let rest = &text[i..];
        let trimmed = rest.trim_start_matches([' ', '\t', '\r', '\n']);
        i += rest.len() - trimmed.len();
        if trimmed.starts_with("<!DOCTYPE") {
            return Some(i);
        }
        let skip = if let Some(pi) = trimmed.strip_prefix("<?") {
            pi.find("?>")? + 4
        } else if let Some(comment) = trimmed.strip_prefix("<!--") {
            comment.find("-->")? + 7
        } else {
            return None;
        };
        i += skip;
    }
}

/// The first element child of `node` with tag `tag`.
fn child<'a, 'i>(node: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == tag)
}

/// Edit distance between two names (case-insensitive), for suggestions.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.to_lowercase().chars().collect();
    let b: Vec<char> = b.to_lowercase().chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The nearest of `names` to `name` (first of the nearest on ties). Bounded work: names longer
/// than 64 characters are not compared (a megabyte name would cost its length squared), and
/// the search stops after about 10⁶ table cells (a file with 10⁵ links is not scanned whole
/// for a suggestion).
fn nearest<'a>(name: &str, names: impl Iterator<Item = &'a str>) -> Option<String> {
    const LONGEST: usize = 64;
    const BUDGET: usize = 1 << 20;
    let a = name.chars().count();
    if a > LONGEST {
        return None;
    }
    let mut spent = 0;
    let mut best: Option<(usize, &str)> = None;
    for n in names {
        let b = n.chars().count();
        if b > LONGEST {
            continue;
        }
        spent += (a + 1) * (b + 1);
        if spent > BUDGET {
            break;
        }
        let d = edit_distance(name, n);
        if best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, n));
        }
    }
    best.map(|(_, n)| n.to_string())
}

impl Urdf {
    /// Parse URDF text into its tree of links and joints. Errors name the element, the attribute
    /// and the line (see [`UrdfError`]); no input panics.
    pub fn parse(text: &str) -> Result<Urdf, UrdfError> {
        let cx = Ctx::new(text);
        let doc = Document::parse(text).map_err(|e| {
            if e == roxmltree::Error::DtdDetected {
                // roxmltree reports no position for a DTD (it says line 1): find it.
                let at = doctype_offset(text).unwrap_or(0);
                let line = cx.line_at(at);
                let start = cx.line_starts[line as usize - 1];
                return UrdfError::Dtd {
                    line,
                    // Columns as an editor shows them: a byte order mark is not one.
                    col: u32::try_from(
                        text[start..at]
                            .trim_start_matches('\u{feff}')
                            .chars()
                            .count()
                            + 1,
                    )
                    .unwrap_or(u32::MAX),
                };
            }
            let pos = e.pos();
            UrdfError::Xml {
                line: pos.row,
                col: pos.col,
                msg: e.to_string(),
            }
        })?;
        let robot = doc.root_element();
        if robot.tag_name().name() != "robot" {
            return Err(UrdfError::NotARobot {
                found: robot.tag_name().name().to_string(),
                line: cx.line(robot),
            });
        }
        let name = robot.attribute("name").unwrap_or("").to_string();

        // Links: name and inertial, in the link frame.
        let mut links: Vec<Link> = Vec::new();
        let mut link_index: HashMap<String, usize> = HashMap::new();
        for node in robot
            .children()
            .filter(|n| n.is_element() && n.tag_name().name() == "link")
        {
            let lname = cx.required_attr(node, "name", "robot")?.to_string();
            let line = cx.line(node);
            if let Some(&k) = link_index.get(&lname) {
                let first_line = links[k].line;
                return Err(UrdfError::Duplicate {
                    kind: "link".into(),
                    name: lname,
                    line,
                    first_line,
                });
            }
            let owner = format!("link {}", name_excerpt(&lname));
            let inertial = match child(node, "inertial") {
                None => None,
                Some(inn) => Some(read_inertial(&cx, inn, &owner, &lname)?),
            };
            link_index.insert(lname.clone(), links.len());
            links.push(Link {
                name: lname,
                line,
                inertial,
            });
        }

        // Joints: type, parent, child, origin, axis, limit, dynamics, mimic.
        let mut joints: Vec<Joint> = Vec::new();
        let mut joint_lines: HashMap<String, u32> = HashMap::new();
        for node in robot
            .children()
            .filter(|n| n.is_element() && n.tag_name().name() == "joint")
        {
            let jname = cx.required_attr(node, "name", "robot")?.to_string();
            let line = cx.line(node);
            if let Some(&first_line) = joint_lines.get(&jname) {
                return Err(UrdfError::Duplicate {
                    kind: "joint".into(),
                    name: jname,
                    line,
                    first_line,
                });
            }
            joint_lines.insert(jname.clone(), line);
            let owner = format!("joint {}", name_excerpt(&jname));
            let kind_s = cx.required_attr(node, "type", &owner)?;
            let kind = match kind_s {
                "revolute" => UrdfKind::Revolute,
                "continuous" => UrdfKind::Continuous,
                "prismatic" => UrdfKind::Prismatic,
                "fixed" => UrdfKind::Fixed,
                "floating" => UrdfKind::Floating,
                "planar" => UrdfKind::Planar,
                other => {
                    return Err(cx.bad(
                        node,
                        "type",
                        &owner,
                        other,
                        "expected revolute, continuous, prismatic, fixed, floating or planar",
                    ));
                }
            };
            let link_of = |role: &str| -> Result<usize, UrdfError> {
                let el = child(node, role).ok_or_else(|| UrdfError::MissingElement {
                    owner: owner.clone(),
                    element: role.to_string(),
                    line,
                })?;
                let lname = cx.required_attr(el, "link", &owner)?;
                link_index
                    .get(lname)
                    .copied()
                    .ok_or_else(|| UrdfError::UnknownLink {
                        joint: jname.clone(),
                        role: role.to_string(),
                        link: lname.to_string(),
                        line: cx.line(el),
                        suggestion: nearest(lname, links.iter().map(|l| l.name.as_str())),
                    })
            };
            let parent = link_of("parent")?;
            let child_link = link_of("child")?;
            let origin = cx.origin(child(node, "origin"), &owner)?;

            // Axis, normalised; a zero axis only matters on a movable joint.
            let axis_node = child(node, "axis");
            let axis_v = match axis_node {
                Some(a) => {
                    let v = cx.numbers::<3>(a, "xyz", &owner, Some([1.0, 0.0, 0.0]))?;
                    Vector3::new(v[0], v[1], v[2])
                }
                None => Vector3::x(),
            };
            // Scaled by its largest entry first, so that `1e308 0 1e308` is an axis, not an
            // overflow to a non-finite "unit" vector; zero below a norm of 1e-12, as written.
            let big = axis_v.amax();
            let unit = (big > 0.0)
                .then(|| Unit::try_new(axis_v / big, 0.0))
                .flatten()
                .filter(|_| big * (axis_v / big).norm() > 1e-12);
            let axis = match unit {
                Some(a) => a,
                None if kind == UrdfKind::Fixed => Vector3::x_axis(),
                None => {
                    return Err(UrdfError::ZeroAxis {
                        joint: jname,
                        line: axis_node.map_or(line, |a| cx.line(a)),
                    });
                }
            };

            // Limits: position (revolute, prismatic), velocity and effort.
            let limit_node = child(node, "limit");
            let limit_line = limit_node.map_or(line, |l| cx.line(l));
            let mut limits = JointLimits::UNLIMITED;
            if let Some(l) = limit_node {
                limits.effort = cx.number(l, "effort", &owner, Some(f64::INFINITY))?;
                limits.velocity = cx.number(l, "velocity", &owner, Some(f64::INFINITY))?;
                if matches!(kind, UrdfKind::Revolute | UrdfKind::Prismatic) {
                    limits.lower = cx.number(l, "lower", &owner, Some(0.0))?;
                    limits.upper = cx.number(l, "upper", &owner, Some(0.0))?;
                }
                if kind == UrdfKind::Prismatic {
                    for (attr, v) in [("lower", limits.lower), ("upper", limits.upper)] {
                        if v.abs() > MAX_LENGTH {
                            return Err(cx.bad(
                                l,
                                attr,
                                &owner,
                                l.attribute(attr).unwrap_or(""),
                                &format!(
                                    "a prismatic travel beyond {MAX_LENGTH:e} m: no robot's \
                                     slide is that long; check the exponent and the unit"
                                ),
                            ));
                        }
                    }
                }
            } else if matches!(kind, UrdfKind::Revolute | UrdfKind::Prismatic) {
                return Err(UrdfError::MissingElement {
                    owner,
                    element: "limit".into(),
                    line,
                });
            }
            let damping = match child(node, "dynamics") {
                Some(d) => cx.number(d, "damping", &owner, Some(0.0))?,
                None => 0.0,
            };
            let mimic = child(node, "mimic").map(|m| cx.line(m));
            joints.push(Joint {
                name: jname,
                line,
                kind,
                parent,
                child: child_link,
                origin,
                axis,
                limits,
                limit_line,
                damping,
                mimic,
            });
        }

        // Tree: one parent per link, no cycle.
        let mut parent_joint: Vec<Option<usize>> = vec![None; links.len()];
        let mut child_joints: Vec<Vec<usize>> = vec![Vec::new(); links.len()];
        for (k, j) in joints.iter().enumerate() {
            if let Some(first) = parent_joint[j.child] {
                return Err(UrdfError::TwoParents {
                    link: links[j.child].name.clone(),
                    first: joints[first].name.clone(),
                    first_line: joints[first].line,
                    second: j.name.clone(),
                    line: j.line,
                });
            }
            parent_joint[j.child] = Some(k);
            child_joints[j.parent].push(k);
        }
        // Cycle check in O(n): 0 = unknown, 1 = on the current walk, 2 = reaches a root.
        let mut state = vec![0u8; links.len()];
        let mut walk = Vec::new();
        for start in 0..links.len() {
            let mut at = start;
            walk.clear();
            while state[at] == 0 {
                state[at] = 1;
                walk.push(at);
                match parent_joint[at] {
                    Some(j) => at = joints[j].parent,
                    None => break,
                }
            }
            if state[at] == 1 && parent_joint[at].is_some() {
                return Err(UrdfError::Cycle {
                    link: links[at].name.clone(),
                    line: links[at].line,
                });
            }
            for &l in &walk {
                state[l] = 2;
            }
        }
        Ok(Urdf {
            name,
            links,
            joints,
            link_index,
            parent_joint,
            child_joints,
        })
    }

    /// The robot's name (`<robot name>`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Link names in file order.
    pub fn links(&self) -> impl Iterator<Item = &str> {
        self.links.iter().map(|l| l.name.as_str())
    }

    /// Joint names in file order.
    pub fn joints(&self) -> impl Iterator<Item = &str> {
        self.joints.iter().map(|j| j.name.as_str())
    }

    /// Links without a parent joint (the roots of the tree; a URDF has one), in file order:
    /// the candidates for a chain's base link.
    pub fn root_links(&self) -> impl Iterator<Item = &str> {
        self.links
            .iter()
            .zip(&self.parent_joint)
            .filter(|(_, p)| p.is_none())
            .map(|(l, _)| l.name.as_str())
    }

    /// Links without a child joint (the leaves of the tree), in file order: the candidates for
    /// a chain's tool link.
    pub fn leaf_links(&self) -> impl Iterator<Item = &str> {
        self.links
            .iter()
            .zip(&self.child_joints)
            .filter(|(_, c)| c.is_empty())
            .map(|(l, _)| l.name.as_str())
    }

    fn find_link(&self, name: &str) -> Result<usize, UrdfError> {
        self.link_index
            .get(name)
            .copied()
            .ok_or_else(|| UrdfError::MissingLink {
                name: name.to_string(),
                suggestion: nearest(name, self.links()),
            })
    }

    /// The serial chain from link `base` to link `tool` (see the module doc for the rules), and
    /// its warnings (off-path movable joints welded at `q = 0`, inertias that break the triangle
    /// inequality), each naming the joint or link.
    pub fn chain(&self, base: &str, tool: &str) -> Result<(Chain, Vec<String>), UrdfError> {
        let b = self.find_link(base)?;
        let t = self.find_link(tool)?;
        let not_a_chain = |reason: String| UrdfError::NotAChain {
            base: base.to_string(),
            tool: tool.to_string(),
            reason,
        };

        // Path: walk up from the tool until the base (the tree has no cycle, checked at parse).
        let mut path = Vec::new();
        let mut at = t;
        while at != b {
            match self.parent_joint[at] {
                Some(j) => {
                    path.push(j);
                    at = self.joints[j].parent;
                }
                None => {
                    return Err(not_a_chain(format!(
                        "{base} is not an ancestor of {tool} (walking up from {tool} ends at the root link {})",
                        self.links[at].name
                    )));
                }
            }
        }
        path.reverse();
        for &j in &path {
            let jt = &self.joints[j];
            if let Some(line) = jt.mimic {
                return Err(UrdfError::Mimic {
                    joint: jt.name.clone(),
                    line,
                });
            }
            if matches!(jt.kind, UrdfKind::Floating | UrdfKind::Planar) {
                return Err(UrdfError::UnsupportedJoint {
                    joint: jt.name.clone(),
                    kind: jt.kind.name().to_string(),
                    line: jt.line,
                });
            }
        }
        if !path.iter().any(|&j| self.joints[j].kind.movable_1dof()) {
            return Err(not_a_chain(if path.is_empty() {
                "they are the same link".to_string()
            } else {
                "no movable joint between them".to_string()
            }));
        }

        // Walk down the path. `x_acc` = pose of the current path link in the current body frame
        // (or in the base frame before the first movable joint).
        let mut warnings = Vec::new();
        let mut joints_out: Vec<ChainJoint> = Vec::new();
        let mut bodies: Vec<BodyBuild> = Vec::new();
        let mut x_acc = Isometry3::identity();
        // Subtree sizes and masses for the warnings, computed once when the first is needed.
        let mut subtree: Option<Vec<(usize, f64)>> = None;
        for (k, &j) in path.iter().enumerate() {
            let jt = &self.joints[j];
            let next = path.get(k + 1).copied();
            if jt.kind == UrdfKind::Fixed {
                x_acc *= jt.origin;
            } else {
                // Placement: the fixed joints since the last body, then this joint's origin.
                joints_out.push(self.chain_joint(jt, x_acc * jt.origin)?);
                bodies.push(BodyBuild {
                    link: jt.child,
                    parts: Vec::new(),
                    merged: Vec::new(),
                });
                // The joint frame is the child link frame: the new body starts there.
                x_acc = Isometry3::identity();
            }
            // The child link and what hangs off it belong to the current body, if any.
            if let Some(body) = bodies.last_mut() {
                self.attach(jt.child, &x_acc, next, body, &mut warnings, &mut subtree);
            }
        }
        let tool_pose = x_acc;

        // Bodies: exact merge, then mass and inertia checks with lines.
        let mut rigid = Vec::with_capacity(bodies.len());
        for bb in &bodies {
            rigid.push(self.finish_body(bb)?);
        }
        let chain = Chain {
            name: self.name.clone(),
            base_link: base.to_string(),
            tool_link: tool.to_string(),
            joints: joints_out,
            bodies: rigid,
            tool: tool_pose,
        };
        warnings.extend(chain.validate()?);
        Ok((chain, warnings))
    }

    /// A movable URDF joint as a [`ChainJoint`] at `placement` (its origin composed after the
    /// fixed joints before it), with its limits and damping checked.
    fn chain_joint(&self, jt: &Joint, placement: Isometry3<f64>) -> Result<ChainJoint, UrdfError> {
        let owner = format!("joint {}", jt.name);
        let bad = |attr: &str, value: f64, reason: &str| UrdfError::BadAttribute {
            owner: owner.clone(),
            element: "limit".into(),
            attr: attr.to_string(),
            value: value.to_string(),
            line: jt.limit_line,
            reason: reason.to_string(),
        };
        let l = jt.limits;
        if l.lower > l.upper {
            return Err(bad("lower", l.lower, "lower exceeds upper"));
        }
        if !(l.velocity > 0.0) {
            return Err(bad("velocity", l.velocity, "must be > 0"));
        }
        if !(l.effort > 0.0) {
            return Err(bad("effort", l.effort, "must be > 0"));
        }
        if !(jt.damping >= 0.0) {
            return Err(UrdfError::BadAttribute {
                owner: owner.clone(),
                element: "dynamics".into(),
                attr: "damping".into(),
                value: jt.damping.to_string(),
                line: jt.line,
                reason: "must be >= 0".into(),
            });
        }
        Ok(ChainJoint {
            name: jt.name.clone(),
            kind: if jt.kind == UrdfKind::Prismatic {
                JointKind::Prismatic
            } else {
                JointKind::Revolute
            },
            placement,
            axis: jt.axis,
            limits: l,
            damping: jt.damping,
        })
    }

    /// Attach link `link` at pose `x_bl` (in the body frame) to `body`, with every subtree hanging
    /// off it except through the path joint `next`. Off-path movable joints are welded at q = 0
    /// with a warning (`subtree`: the links' subtree sizes and masses, filled on first use).
    fn attach(
        &self,
        link: usize,
        x_bl: &Isometry3<f64>,
        next: Option<usize>,
        body: &mut BodyBuild,
        warnings: &mut Vec<String>,
        subtree: &mut Option<Vec<(usize, f64)>>,
    ) {
        // Depth-first with an explicit stack (no recursion: a long branch cannot overflow it).
        let mut stack = vec![(link, *x_bl)];
        while let Some((l, x)) = stack.pop() {
            body.add(&self.links[l], &x);
            if l != body.link && self.links[l].inertial.is_some() {
                body.merged.push(self.links[l].name.clone());
            }
            for &j in self.child_joints[l].iter().rev() {
                if l == link && Some(j) == next {
                    continue;
                }
                let jt = &self.joints[j];
                if jt.kind != UrdfKind::Fixed {
                    let (n, m) = subtree.get_or_insert_with(|| self.subtree_masses())[jt.child];
                    warnings.push(format!(
                        "joint {} ({}) branches off the chain at link {}: its subtree ({n} link{}, {m} kg) is welded to the body of link {} at q = 0",
                        jt.name,
                        jt.kind.name(),
                        self.links[l].name,
                        if n == 1 { "" } else { "s" },
                        self.links[body.link].name,
                    ));
                }
                stack.push((jt.child, x * jt.origin));
            }
        }
    }

    /// Number of links and total mass of the subtree rooted at each link, in O(n) for the whole
    /// tree (a per-joint walk would be quadratic in a long branch of welded joints).
    fn subtree_masses(&self) -> Vec<(usize, f64)> {
        let mut out: Vec<(usize, f64)> = self
            .links
            .iter()
            .map(|l| (1, l.inertial.as_ref().map_or(0.0, |i| i.mass)))
            .collect();
        // Parents before children (the tree has no cycle, checked at parse), then sum upward.
        let mut order: Vec<usize> = (0..self.links.len())
            .filter(|&l| self.parent_joint[l].is_none())
            .collect();
        let mut k = 0;
        while k < order.len() {
            let l = order[k];
            order.extend(self.child_joints[l].iter().map(|&j| self.joints[j].child));
            k += 1;
        }
        for &l in order.iter().rev() {
            if let Some(j) = self.parent_joint[l] {
                let p = self.joints[j].parent;
                out[p].0 += out[l].0;
                out[p].1 += out[l].1;
            }
        }
        out
    }

    /// Combine the parts of a body and check its mass and inertia.
    fn finish_body(&self, bb: &BodyBuild) -> Result<RigidBody, UrdfError> {
        let link = &self.links[bb.link];
        let (mass, com, inertia) = combine(&bb.parts);
        let (mass_line, inertia_line) = link
            .inertial
            .as_ref()
            .map_or((link.line, link.line), |i| (i.mass_line, i.inertia_line));
        let merged = if bb.merged.is_empty() {
            String::new()
        } else {
            format!(" (with the fixed links {} merged)", bb.merged.join(", "))
        };
        if !(mass > 0.0 && mass.is_finite()) {
            return Err(UrdfError::BadMass {
                link: link.name.clone(),
                value: mass,
                line: mass_line,
                reason: format!("a moving link must have a mass > 0{merged}"),
            });
        }
        if !inertia.iter().all(|v| v.is_finite()) {
            return Err(UrdfError::BadInertia {
                link: link.name.clone(),
                line: inertia_line,
                reason: format!("inertia is not finite{merged}"),
            });
        }
        if inertia.iter().any(|v| v.abs() > MAX_LINK_MASS) {
            return Err(UrdfError::BadInertia {
                link: link.name.clone(),
                line: inertia_line,
                reason: format!(
                    "an inertia entry beyond {MAX_LINK_MASS:e} kg m²{merged}: no robot link has \
                     one; check the exponent and the unit"
                ),
            });
        }
        let ev = inertia.symmetric_eigenvalues();
        let (lo, hi) = (ev.min(), ev.max());
        if !(lo > 1e-12 * hi.max(f64::MIN_POSITIVE)) {
            return Err(UrdfError::BadInertia {
                link: link.name.clone(),
                line: inertia_line,
                reason: format!(
                    "inertia is not positive definite{merged}: principal moments {:.4e}, {:.4e}, {:.4e} kg m²",
                    ev[0], ev[1], ev[2]
                ),
            });
        }
        Ok(RigidBody {
            name: link.name.clone(),
            mass,
            com,
            inertia,
        })
    }
}

/// A link or joint name for a message: whole up to 120 characters (every real one), else
/// its first 120 and how long it was (a megabyte name is not echoed).
fn name_excerpt(v: &str) -> String {
    excerpt_n(v, 120)
}

/// A value as written, for a message: whole up to 40 characters, else its first 40 and how
/// long it was (a 300-digit literal or a megabyte attribute is not echoed).
fn excerpt(v: &str) -> String {
    excerpt_n(v, 40)
}

fn excerpt_n(v: &str, keep: usize) -> String {
    match v.char_indices().nth(keep) {
        None => v.to_string(),
        Some((end, _)) => format!("{}… ({} characters)", &v[..end], v.chars().count()),
    }
}

/// A number for a message: as Rust prints it between 1e-4 and 1e6 (`3.7`), in scientific
/// notation outside (`1e308`, not 309 digits).
fn short(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Largest link mass the loader takes, kg: checked when the file is read, so that a typo
/// (1e308) is blamed on its line rather than on whatever the arm then cannot do.
pub const MAX_LINK_MASS: f64 = 1e6;

/// Largest offset the loader takes in an `<origin xyz>` (joint or inertial) and largest
/// prismatic limit, m: checked when the file is read, so that a typo (1e308) is refused on its
/// line rather than overflowing the kinematics (a body 1e200 m out has an infinite moment of
/// inertia about the base). A kilometre is beyond any robot, and far inside what the dynamics
/// computes finitely (16 joints × 1e6 kg × (16 km)² ≈ 4e15).
pub const MAX_LENGTH: f64 = 1e3;

/// Read `<inertial>` into the link frame: `com = p_LC`, `I_L = R_LC I_C R_LCᵀ`.
fn read_inertial(cx: &Ctx, node: Node, owner: &str, link: &str) -> Result<Inertial, UrdfError> {
    let x_lc = cx.origin(child(node, "origin"), owner)?;
    let line = cx.line(node);
    let (mass, mass_line) = match child(node, "mass") {
        Some(m) => (
            cx.number(m, "value", owner, None)?,
            cx.attr_line(m, "value"),
        ),
        None => {
            return Err(UrdfError::MissingElement {
                owner: owner.to_string(),
                element: "mass".into(),
                line,
            });
        }
    };
    if mass < 0.0 {
        return Err(UrdfError::BadMass {
            link: link.to_string(),
            value: mass,
            line: mass_line,
            reason: "a mass must not be negative".into(),
        });
    }
    if mass > MAX_LINK_MASS {
        return Err(UrdfError::BadMass {
            link: link.to_string(),
            value: mass,
            line: mass_line,
            reason: format!(
                "beyond {MAX_LINK_MASS:e} kg no link is a robot's (the heaviest industrial \
                 arms weigh a few tonnes in all); check the exponent and the unit"
            ),
        });
    }
    let (i_c, inertia_line) = match child(node, "inertia") {
        Some(i) => {
            let g = |a: &str| cx.number(i, a, owner, Some(0.0));
            let (ixx, ixy, ixz) = (g("ixx")?, g("ixy")?, g("ixz")?);
            let (iyy, iyz, izz) = (g("iyy")?, g("iyz")?, g("izz")?);
            (
                Matrix3::new(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz),
                cx.line(i),
            )
        }
        None => (Matrix3::zeros(), line),
    };
    let r = x_lc.rotation.to_rotation_matrix();
    let mut i_l = r.matrix() * i_c * r.matrix().transpose();
    // Keep it exactly symmetric after the rotation.
    i_l = (i_l + i_l.transpose()) * 0.5;
    Ok(Inertial {
        mass,
        com: x_lc.translation.vector,
        inertia: i_l,
        mass_line,
        inertia_line,
    })
}

/// One part of a body: mass, centre of mass and inertia about it, in body axes.
#[derive(Clone, Debug)]
struct Part {
    mass: f64,
    com: Vector3<f64>,
    inertia: Matrix3<f64>,
}

/// A moving body being assembled: the link carrying its frame and its parts.
struct BodyBuild {
    link: usize,
    parts: Vec<Part>,
    /// Names of the other links merged in.
    merged: Vec<String>,
}

impl BodyBuild {
    /// Add link `l` placed at `x_bl` in the body frame.
    fn add(&mut self, l: &Link, x_bl: &Isometry3<f64>) {
        if let Some(i) = &l.inertial {
            let r = x_bl.rotation.to_rotation_matrix();
            let inertia = r.matrix() * i.inertia * r.matrix().transpose();
            self.parts.push(Part {
                mass: i.mass,
                com: (x_bl * Point3::from(i.com)).coords,
                inertia: (inertia + inertia.transpose()) * 0.5,
            });
        }
    }
}

/// Exact combination of rigid parts (same body axes): total mass, mass-weighted centre of mass,
/// and `I = Σ I_i + m_i (|d_i|² 𝟙 − d_i d_iᵀ)` with `d_i = c_i − c` (parallel-axis theorem).
fn combine(parts: &[Part]) -> (f64, Vector3<f64>, Matrix3<f64>) {
    if let [p] = parts {
        return (p.mass, p.com, p.inertia);
    }
    let mass: f64 = parts.iter().map(|p| p.mass).sum();
    let com = if mass > 0.0 {
        parts
            .iter()
            .fold(Vector3::zeros(), |s, p| s + p.com * p.mass)
            / mass
    } else {
        Vector3::zeros()
    };
    let mut inertia = Matrix3::zeros();
    for p in parts {
        let d = p.com - com;
        inertia +=
            p.inertia + (Matrix3::identity() * d.norm_squared() - d * d.transpose()) * p.mass;
    }
    (mass, com, inertia)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_is_fixed_axis_roll_pitch_yaw() {
        let (r, p, y) = (0.3_f64, -0.7_f64, 1.1_f64);
        let rx = Matrix3::new(1.0, 0.0, 0.0, 0.0, r.cos(), -r.sin(), 0.0, r.sin(), r.cos());
        let ry = Matrix3::new(p.cos(), 0.0, p.sin(), 0.0, 1.0, 0.0, -p.sin(), 0.0, p.cos());
        let rz = Matrix3::new(y.cos(), -y.sin(), 0.0, y.sin(), y.cos(), 0.0, 0.0, 0.0, 1.0);
        let want = rz * ry * rx;
        let got = rpy_to_rotation([r, p, y]).to_rotation_matrix().into_inner();
        assert!((got - want).abs().max() < 1e-15, "{got} vs {want}");
    }

    #[test]
    fn edit_distance_and_nearest() {
        assert_eq!(edit_distance("tool0", "tool0"), 0);
        assert_eq!(edit_distance("tool", "tool0"), 1);
        assert_eq!(edit_distance("Tool0", "tool0"), 0);
        assert_eq!(edit_distance("", "abc"), 3);
        let names = ["base_link", "tool0", "wrist_3_link"];
        assert_eq!(
            nearest("wrist3_link", names.iter().copied()).as_deref(),
            Some("wrist_3_link")
        );
    }

    #[test]
    fn combine_two_halves_at_one_point_is_the_whole() {
        let i = Matrix3::new(0.3, 0.01, -0.02, 0.01, 0.2, 0.03, -0.02, 0.03, 0.25);
        let c = Vector3::new(0.1, -0.2, 0.3);
        let half = Part {
            mass: 1.5,
            com: c,
            inertia: i * 0.5,
        };
        let (m, com, ii) = combine(&[half.clone(), half]);
        assert_eq!(m, 3.0);
        assert!((com - c).abs().max() < 1e-16);
        assert!((ii - i).abs().max() < 1e-16);
    }

    #[test]
    fn numbers_reject_non_finite_and_wrong_counts() {
        for bad in ["1 2", "1 2 3 4", "1 nan 2", "inf 0 0", "1 2 x"] {
            let text = format!(
                r#"<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="fixed"><parent link="a"/><child link="b"/><origin xyz="{bad}"/></joint></robot>"#
            );
            match Urdf::parse(&text) {
                Err(UrdfError::BadAttribute {
                    owner, attr, line, ..
                }) => {
                    assert_eq!(owner, "joint j");
                    assert_eq!(attr, "xyz");
                    assert_eq!(line, 2);
                }
                other => panic!("{bad}: {other:?}"),
            }
        }
    }
}
