// ez-tree's own rate: Tree.generate() over every preset, `count` trees in all (presets cycled,
// seeds 1, 2, … per preset), single-threaded in Node. Prints one JSON line: trees, seconds of
// generate() (import and start-up excluded) and the mean triangle counts of branches and leaves.
//
// ez-tree loads its bark and leaf textures through three's ImageLoader when it is imported;
// Node has no DOM, so the loader gets inert image elements. The textures never load, and
// generate() builds the same geometry without them (materials only reference them).
globalThis.document = {
  createElementNS: () => ({ style: {}, addEventListener() {}, removeEventListener() {} }),
};
const { Tree, TreePreset } = await import('@dgreenheck/ez-tree');

const count = Number(process.argv[2] ?? 300);
const presets = Object.keys(TreePreset);
const triangles = (mesh) =>
  mesh.geometry.index ? mesh.geometry.index.count / 3 : mesh.geometry.attributes.position.count / 3;

let branch = 0;
let leaf = 0;
const start = performance.now();
for (let i = 0; i < count; ++i) {
  const tree = new Tree();
  tree.loadPreset(presets[i % presets.length]);
  tree.options.seed = 1 + Math.floor(i / presets.length);
  tree.generate();
  branch += triangles(tree.branchesMesh);
  leaf += triangles(tree.leavesMesh);
}
const seconds = (performance.now() - start) / 1000;
console.log(JSON.stringify({
  trees: count, seconds, presets: presets.length,
  branch_triangles: Math.round(branch / count), leaf_triangles: Math.round(leaf / count),
}));
