// Entry of the vendored three.js bundle: the classes the lcpbench page uses, plus OrbitControls.
export {
  AmbientLight, BoxGeometry, BufferAttribute, BufferGeometry, CapsuleGeometry, Color,
  DirectionalLight, DoubleSide, DynamicDrawUsage, Float32BufferAttribute, GridHelper,
  HemisphereLight, InstancedMesh, LineBasicMaterial, LineSegments, Matrix4, Mesh,
  MeshBasicMaterial, MeshStandardMaterial, Object3D, PerspectiveCamera, PlaneGeometry,
  Quaternion, Scene, SphereGeometry, Vector3, WebGLRenderer, REVISION,
} from 'three';
export { OrbitControls } from 'three/addons/controls/OrbitControls.js';
