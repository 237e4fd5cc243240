#include "tracer/model_loader.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>

#include "calibration/display/srgb_transfer.h"
#include "common/input_error.h"
#include "tracer/model_animation_import.h"
#include "tracer/ply_header_check.h"
#include "tracer/scene_fixtures.h"
#include "tracer/texture_image.h"

namespace parallax {
namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// The files a model names (an OBJ's mtllib, a glTF's buffers, ...) are opened by assimp
// itself: only regular ones, so that one naming a FIFO or a device cannot block the loader
// (and the daemon's conductor with it) for ever.
class RegularFilesOnly : public Assimp::DefaultIOSystem {
 public:
  using DefaultIOSystem::Exists;
  using DefaultIOSystem::Open;
  bool Exists(const char* file) const override {
    struct stat st;
    return ::stat(file, &st) == 0 && S_ISREG(st.st_mode);
  }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    if (!Exists(file)) return nullptr;
    return DefaultIOSystem::Open(file, mode);
  }
};

Eigen::Matrix4d toEigen(const aiMatrix4x4& m) {
  Eigen::Matrix4d out;
  out << m.a1, m.a2, m.a3, m.a4, m.b1, m.b2, m.b3, m.b4, m.c1, m.c2, m.c3, m.c4, m.d1, m.d2, m.d3,
      m.d4;
  return out;
}

// A texture stored inside the model file (glTF binary, FBX): decoded through OpenImageIO from
// memory into an inline Texture. Returns false with `error` set when it cannot be decoded.
bool decodeEmbedded(const aiTexture& embedded, Texture* out, std::string* error) {
  if (embedded.mHeight != 0) {
    // Raw ARGB8888 texels.
    const size_t count = static_cast<size_t>(embedded.mWidth) * embedded.mHeight;
    if (embedded.mWidth > 65536 || embedded.mHeight > 65536) {
      *error = "embedded texture too large";
      return false;
    }
    out->width = static_cast<int>(embedded.mWidth);
    out->height = static_cast<int>(embedded.mHeight);
    out->pixels.resize(count * 3);
    for (size_t i = 0; i < count; ++i) {
      const aiTexel& t = embedded.pcData[i];
      out->pixels[3 * i] = linearFromSrgb(t.r / 255.0f);
      out->pixels[3 * i + 1] = linearFromSrgb(t.g / 255.0f);
      out->pixels[3 * i + 2] = linearFromSrgb(t.b / 255.0f);
    }
    return true;
  }
  OIIO::Filesystem::IOMemReader memory(embedded.pcData, embedded.mWidth);
  const std::string name = std::string("embedded.") + embedded.achFormatHint;
  auto input = OIIO::ImageInput::open(name, nullptr, &memory);
  if (!input) {
    *error = OIIO::geterror();
    return false;
  }
  const OIIO::ImageSpec spec = input->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.width > 65536 || spec.height > 65536 ||
      spec.nchannels <= 0 || spec.nchannels > 4) {
    *error = "unsupported embedded image size or channel count";
    return false;
  }
  // A few compressed bytes can claim a huge picture: its size is checked before it is decoded.
  if (static_cast<long>(spec.width) * spec.height > TextureImage::kMaxFilePixels) {
    *error = fmt::format("{}x{} pixels, more than the {} a texture may have", spec.width,
                         spec.height, TextureImage::kMaxFilePixels);
    return false;
  }
  std::vector<float> data(static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) *
                          static_cast<size_t>(spec.nchannels));
  if (!input->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, data.data())) {
    *error = input->geterror();
    return false;
  }
  out->width = spec.width;
  out->height = spec.height;
  out->pixels.resize(static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height) * 3);
  const bool decode = spec.format == OIIO::TypeDesc::UINT8 || spec.format == OIIO::TypeDesc::UINT16;
  for (size_t i = 0; i < out->pixels.size() / 3; ++i) {
    for (size_t c = 0; c < 3; ++c) {
      const float v = data[i * static_cast<size_t>(spec.nchannels) + (spec.nchannels >= 3 ? c : 0)];
      const float clean = std::isfinite(v) ? std::max(v, 0.0f) : 0.0f;
      out->pixels[3 * i + c] = decode ? linearFromSrgb(clean) : clean;
    }
  }
  return true;
}

Rgb colorOf(const aiMaterial& m, const char* key, unsigned type, unsigned index,
            const Rgb& fallback, bool* present) {
  aiColor4D c;
  if (m.Get(key, type, index, c) == AI_SUCCESS && std::isfinite(c.r) && std::isfinite(c.g) &&
      std::isfinite(c.b)) {
    *present = true;
    return Rgb(std::max(c.r, 0.0f), std::max(c.g, 0.0f), std::max(c.b, 0.0f));
  }
  *present = false;
  return fallback;
}

}  // namespace

std::string resolveTexturePath(const std::string& reference, const std::string& modelDirectory,
                               bool* found) {
  std::string cleaned = reference;
  std::replace(cleaned.begin(), cleaned.end(), '\\', '/');
  while (cleaned.rfind("./", 0) == 0) cleaned = cleaned.substr(2);
  const fs::path candidate =
      fs::path(cleaned).is_absolute() ? fs::path(cleaned) : fs::path(modelDirectory) / cleaned;
  std::error_code ec;
  if (fs::is_regular_file(candidate, ec)) {
    *found = true;
    return candidate.string();
  }
  // Files made on Windows often name their textures in another case than the disk has.
  const fs::path folder = candidate.parent_path();
  const std::string wanted = lower(candidate.filename().string());
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    if (lower(it->path().filename().string()) == wanted && it->is_regular_file(ec)) {
      *found = true;
      return it->path().string();
    }
  }
  *found = false;
  return candidate.string();
}

ModelLoadReport appendModel(const std::string& path, const ModelLoadOptions& options, Scene* scene,
                            ModelAnimation* animation) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError({path, "", 0}, "no such model file");
  const std::uintmax_t fileSize = fs::file_size(path, ec);
  if (fileSize == 0) throw InputError({path, "", 0}, "the model file is empty (0 bytes)");
  {
    // The header is all the check needs: the first 64 KiB (a header longer than that is left
    // to assimp).
    std::string head(64 << 10, '\0');
    std::ifstream in(path, std::ios::binary);
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<size_t>(in.gcount()));
    requirePlyCountsFit(path, head, static_cast<double>(fileSize));
  }
  Assimp::Importer importer;
  importer.SetIOHandler(new RegularFilesOnly);  // the importer owns it
  // Drop points and lines (nothing a ray can hit); triangulate quads and polygons; make normals
  // where the file has none; reject NaN data; merge identical vertices so smooth normals smooth.
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                              aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  const aiScene* model = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure);
  auto failed = [&](const aiScene* s) {
    return !s || !s->mRootNode || (s->mFlags & AI_SCENE_FLAGS_INCOMPLETE);
  };
  auto reason = [&] {
    std::string r = importer.GetErrorString();
    return r.empty() ? std::string("the file holds no complete scene") : r;
  };
  if (failed(model)) throw InputError({path, "", 0}, "cannot read the model: " + reason());
  ModelLoadReport report;
  // The rest runs as a second step so the report can say which meshes came without normals
  // (GenSmoothNormals leaves meshes that have them alone).
  for (unsigned i = 0; i < model->mNumMeshes; ++i)
    report.generatedNormals += model->mMeshes[i]->mNormals ? 0 : 1;
  model =
      importer.ApplyPostProcessing(aiProcess_GenSmoothNormals | aiProcess_JoinIdenticalVertices |
                                   aiProcess_FindInvalidData | aiProcess_FindDegenerates);
  if (failed(model)) throw InputError({path, "", 0}, "cannot post-process the model: " + reason());
  const std::string directory = fs::path(path).parent_path().string();

  // Materials (and the textures they reference).
  const int materialBase = static_cast<int>(scene->materials.size());
  for (unsigned i = 0; i < model->mNumMaterials; ++i) {
    const aiMaterial& m = *model->mMaterials[i];
    Material material;
    aiString name;
    if (m.Get(AI_MATKEY_NAME, name) == AI_SUCCESS) material.name = name.C_Str();
    bool present = false;
    material.diffuse = colorOf(m, AI_MATKEY_BASE_COLOR, Rgb(0.8f, 0.8f, 0.8f), &present);
    if (!present)
      material.diffuse = colorOf(m, AI_MATKEY_COLOR_DIFFUSE, Rgb(0.8f, 0.8f, 0.8f), &present);
    // An all-black diffuse colour from an exporter usually means "texture only".
    if (material.diffuse.maxCoeff() <= 0.0f) material.diffuse = Rgb(0.8f, 0.8f, 0.8f);
    float shininess = 0.0f;
    const Rgb specular = colorOf(m, AI_MATKEY_COLOR_SPECULAR, Rgb::Zero(), &present);
    if (m.Get(AI_MATKEY_SHININESS, shininess) == AI_SUCCESS && std::isfinite(shininess) &&
        shininess > 1.0f && specular.maxCoeff() > 0.0f) {
      material.specular = specular;
      material.shininess = std::min(shininess, 1000.0f);
    }
    material.emission = colorOf(m, AI_MATKEY_COLOR_EMISSIVE, Rgb::Zero(), &present);
    aiString texturePath;
    const bool textured = m.GetTexture(aiTextureType_DIFFUSE, 0, &texturePath) == AI_SUCCESS ||
                          m.GetTexture(aiTextureType_BASE_COLOR, 0, &texturePath) == AI_SUCCESS;
    if (textured && texturePath.length > 0) {
      Texture texture;
      texture.fallback = material.diffuse;
      const aiTexture* embedded = model->GetEmbeddedTexture(texturePath.C_Str());
      std::string error;
      bool usable = true;
      if (embedded) {
        usable = decodeEmbedded(*embedded, &texture, &error);
      } else {
        bool found = false;
        texture.path = resolveTexturePath(texturePath.C_Str(), directory, &found);
        if (!found) {
          usable = false;
          error = "file not found: " + texture.path;
        }
      }
      if (usable) {
        // The texture carries the colour; the material's own colour would darken it twice.
        material.diffuse = Rgb::Ones();
        material.diffuseTexture = scene->addTexture(std::move(texture));
        ++report.textures;
      } else {
        ++report.texturesMissing;
        report.warnings.push_back(
            fmt::format("{}: material \"{}\": texture \"{}\" unusable ({}); using its colour", path,
                        material.name, texturePath.C_Str(), error));
      }
    }
    scene->addMaterial(std::move(material));
    ++report.materials;
  }
  if (model->mNumMaterials == 0) scene->addMaterial(Material::makeDiffuse({0.8f, 0.8f, 0.8f}));

  // Meshes.
  std::vector<int> meshIndex(model->mNumMeshes, -1);
  for (unsigned i = 0; i < model->mNumMeshes; ++i) {
    const aiMesh& source = *model->mMeshes[i];
    if (!(source.mPrimitiveTypes & aiPrimitiveType_TRIANGLE) || source.mNumFaces == 0) continue;
    Mesh mesh;
    mesh.name = source.mName.C_Str();
    mesh.material =
        materialBase +
        static_cast<int>(std::min(source.mMaterialIndex, std::max(model->mNumMaterials, 1u) - 1));
    mesh.positions.reserve(source.mNumVertices);
    for (unsigned v = 0; v < source.mNumVertices; ++v) {
      const aiVector3D& p = source.mVertices[v];
      mesh.positions.emplace_back(p.x, p.y, p.z);
    }
    if (source.mNormals) {
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiVector3D& n = source.mNormals[v];
        // FindInvalidData may leave a zero normal; the tracer falls back to the face normal.
        mesh.normals.emplace_back(std::isfinite(n.x) ? n.x : 0.0f, std::isfinite(n.y) ? n.y : 0.0f,
                                  std::isfinite(n.z) ? n.z : 0.0f);
      }
    }
    if (source.mTextureCoords[0]) {
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiVector3D& t = source.mTextureCoords[0][v];
        mesh.uvs.emplace_back(std::isfinite(t.x) ? t.x : 0.0f, std::isfinite(t.y) ? t.y : 0.0f);
      }
    }
    if (source.mColors[0]) {
      for (unsigned v = 0; v < source.mNumVertices; ++v) {
        const aiColor4D& c = source.mColors[0][v];
        mesh.colors.emplace_back(std::clamp(std::isfinite(c.r) ? c.r : 0.0f, 0.0f, 1e6f),
                                 std::clamp(std::isfinite(c.g) ? c.g : 0.0f, 0.0f, 1e6f),
                                 std::clamp(std::isfinite(c.b) ? c.b : 0.0f, 0.0f, 1e6f));
      }
    }
    for (unsigned f = 0; f < source.mNumFaces; ++f) {
      const aiFace& face = source.mFaces[f];
      if (face.mNumIndices != 3) continue;  // stray points/lines after triangulation
      mesh.triangles.push_back({face.mIndices[0], face.mIndices[1], face.mIndices[2]});
    }
    if (mesh.triangles.empty()) continue;
    meshIndex[i] = scene->addMesh(std::move(mesh), false);
  }

  // Instances from the node hierarchy, with the model's own transforms (parents first).
  const std::vector<FlatNode> nodes = flattenNodes(*model, path);
  struct Placed {
    int mesh;
    Eigen::Affine3d transform;
    int node;
    unsigned source;
  };
  std::vector<Placed> placed;
  std::vector<Eigen::Affine3d> global(nodes.size());
  for (size_t n = 0; n < nodes.size(); ++n) {
    const aiNode& node = *nodes[n].node;
    const Eigen::Affine3d parent = nodes[n].parent >= 0
                                       ? global[static_cast<size_t>(nodes[n].parent)]
                                       : Eigen::Affine3d::Identity();
    global[n] = parent * Eigen::Affine3d(toEigen(node.mTransformation));
    if (!global[n].matrix().allFinite()) global[n] = parent;
    if (node.mNumMeshes > 0 && !node.mMeshes) continue;
    for (unsigned k = 0; k < node.mNumMeshes; ++k) {
      const unsigned m = node.mMeshes[k];
      if (m < meshIndex.size() && meshIndex[m] >= 0)
        placed.push_back({meshIndex[m], global[n], static_cast<int>(n), m});
    }
  }
  if (placed.empty()) throw InputError({path, "", 0}, "the model holds no triangles");

  // An animated model starts in its rest pose as the animation evaluates it: rigid parts at
  // their nodes' transforms, skinned meshes deformed by their bones (in model space).
  const bool animate = animation && model->mNumAnimations > 0;
  if (animate) {
    std::vector<PlacedMesh> instances;
    const int firstInstance = static_cast<int>(scene->instances.size());
    for (size_t i = 0; i < placed.size(); ++i)
      instances.push_back({firstInstance + static_cast<int>(i), placed[i].node, placed[i].source});
    *animation =
        importAnimation(*model, nodes, meshIndex, instances, *scene, path, &report.warnings);
    const std::vector<Eigen::Affine3d> rest = animation->nodeTransforms(-1, 0.0);
    for (Placed& p : placed) p.transform = rest[static_cast<size_t>(p.node)];
    for (const SkinnedPart& part : animation->skinnedParts) {
      Mesh& mesh = scene->meshes[static_cast<size_t>(part.mesh)];
      animation->skin(part, rest, &mesh.positions, &mesh.normals);
    }
    std::set<int> skinnedMeshes;
    for (const SkinnedPart& part : animation->skinnedParts) skinnedMeshes.insert(part.mesh);
    for (Placed& p : placed) {
      if (skinnedMeshes.count(p.mesh)) p.transform = Eigen::Affine3d::Identity();
    }
  }

  // Normalise: bounding box in model space → bottom centre at the origin, `targetHeight` tall.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (const Placed& p : placed) {
    for (const Eigen::Vector3d& v : scene->meshes[static_cast<size_t>(p.mesh)].positions) {
      const Eigen::Vector3d q = p.transform * v;
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
  }
  Eigen::Affine3d normalise = Eigen::Affine3d::Identity();
  if (options.targetHeight > 0.0) {
    const double height = hi.y() - lo.y();
    const double scale = height > 0.0 ? options.targetHeight / height : 1.0;
    normalise = Eigen::Affine3d(Eigen::Scaling(scale)) *
                Eigen::Translation3d(-0.5 * (lo.x() + hi.x()), -lo.y(), -0.5 * (lo.z() + hi.z()));
  }
  for (const Placed& p : placed) {
    scene->addInstance(p.mesh, options.worldFromModel * normalise * p.transform);
    ++report.meshes;
    report.triangles +=
        static_cast<long>(scene->meshes[static_cast<size_t>(p.mesh)].triangles.size());
  }
  if (animate) {
    animation->normalisation = normalise;
    animation->placement = options.worldFromModel;
    animation->measureMotionBounds(*scene);
    if (!animation->motionBounds.min.allFinite() || !animation->motionBounds.max.allFinite())
      throw InputError({path, "animations", 0},
                       "the animation moves vertices to non-finite places");
    animation->motionBoundsIndex = static_cast<int>(scene->motionBounds.size());
    scene->motionBounds.push_back(animation->placedMotionBounds());
    report.animations = static_cast<int>(animation->clips.size());
    report.skinnedMeshes = static_cast<int>(animation->skinnedParts.size());
  }
  for (const std::string& w : report.warnings) spdlog::warn("{}", w);
  return report;
}

Scene loadModelScene(const std::string& path, ModelLoadReport* report) {
  Scene scene;
  scene.name = fs::path(path).stem().string();
  const ModelLoadReport r = appendModel(path, ModelLoadOptions{}, &scene);
  if (report) *report = r;
  addPaperLights(&scene);
  scene.ambient = {0.05f, 0.05f, 0.05f};
  scene.background = {0.05f, 0.06f, 0.08f};
  scene.worldBox = scene.geometryBounds();
  return scene;
}

}  // namespace parallax
