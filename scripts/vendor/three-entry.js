// The part of three.js the viewer uses, bundled by scripts/vendor_refresh.sh into
// src/seeing/viewer/vendor/three.min.js as one classic script that defines the global `THREE`.
// Only the names listed here are kept (esbuild drops the rest), so the bundle stays small:
// to use another three.js name in the viewer, add it here (one per line, sorted by kind) and
// run scripts/vendor_refresh.sh.
export {
  // Scene graph, cameras, renderer
  Scene,
  PerspectiveCamera,
  OrthographicCamera,
  WebGLRenderer,
  Color,
  Fog,
  Mesh,
  InstancedMesh,
  Group,
  Object3D,
  Clock,
  Raycaster,
  // Geometries
  BoxGeometry,
  SphereGeometry,
  CylinderGeometry,
  CapsuleGeometry,
  PlaneGeometry,
  BufferGeometry,
  BufferAttribute,
  Float32BufferAttribute,
  EdgesGeometry,
  // Materials, lines, points, sprites
  MeshStandardMaterial,
  MeshLambertMaterial,
  MeshPhongMaterial,
  MeshBasicMaterial,
  LineBasicMaterial,
  LineSegments,
  Line,
  Points,
  PointsMaterial,
  CanvasTexture,
  Sprite,
  SpriteMaterial,
  // Lights
  AmbientLight,
  HemisphereLight,
  DirectionalLight,
  // Helpers
  GridHelper,
  AxesHelper,
  ArrowHelper,
  // Maths
  Vector2,
  Vector3,
  Vector4,
  Quaternion,
  Matrix4,
  Euler,
  Spherical,
  Box3,
  Sphere,
  MathUtils,
  // Constants
  SRGBColorSpace,
  PCFSoftShadowMap,
  PCFShadowMap,
  DoubleSide,
  FrontSide,
} from 'three';
