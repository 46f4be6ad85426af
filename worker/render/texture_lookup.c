/* The bilinear texture lookup the renderer calls at every textured hit, and its prefetch
 * (texture_lookup.h), over the decoded textures of the scene model (worker/scene/texture.h). */
#include "texture_lookup.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>

/* 8-bit value -> linear value: v / 255, and the sRGB decoding of IEC 61966-2-1,
 * c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055)^2.4 with c = v / 255, both computed in
 * double and rounded to float. Written out (tests/worker/scene/test_texture.c checks every entry
 * against the formula) so the lookup needs no initialisation, no lock and no pow. */
static const float linear_table[256] = {
  0.0f, 0.00392156886f, 0.00784313772f, 0.0117647061f, 0.0156862754f, 0.0196078438f,
  0.0235294122f, 0.0274509806f, 0.0313725509f, 0.0352941193f, 0.0392156877f, 0.0431372561f,
  0.0470588244f, 0.0509803928f, 0.0549019612f, 0.0588235296f, 0.0627451017f, 0.0666666701f,
  0.0705882385f, 0.0745098069f, 0.0784313753f, 0.0823529437f, 0.0862745121f, 0.0901960805f,
  0.0941176489f, 0.0980392173f, 0.101960786f, 0.105882354f, 0.109803922f, 0.113725491f,
  0.117647059f, 0.121568628f, 0.125490203f, 0.129411772f, 0.13333334f, 0.137254909f,
  0.141176477f, 0.145098045f, 0.149019614f, 0.152941182f, 0.156862751f, 0.160784319f,
  0.164705887f, 0.168627456f, 0.172549024f, 0.176470593f, 0.180392161f, 0.184313729f,
  0.188235298f, 0.192156866f, 0.196078435f, 0.200000003f, 0.203921571f, 0.20784314f,
  0.211764708f, 0.215686277f, 0.219607845f, 0.223529413f, 0.227450982f, 0.23137255f,
  0.235294119f, 0.239215687f, 0.243137255f, 0.247058824f, 0.250980407f, 0.254901975f,
  0.258823544f, 0.262745112f, 0.266666681f, 0.270588249f, 0.274509817f, 0.278431386f,
  0.282352954f, 0.286274523f, 0.290196091f, 0.294117659f, 0.298039228f, 0.301960796f,
  0.305882365f, 0.309803933f, 0.313725501f, 0.31764707f, 0.321568638f, 0.325490206f,
  0.329411775f, 0.333333343f, 0.337254912f, 0.34117648f, 0.345098048f, 0.349019617f,
  0.352941185f, 0.356862754f, 0.360784322f, 0.36470589f, 0.368627459f, 0.372549027f,
  0.376470596f, 0.380392164f, 0.384313732f, 0.388235301f, 0.392156869f, 0.396078438f,
  0.400000006f, 0.403921574f, 0.407843143f, 0.411764711f, 0.41568628f, 0.419607848f,
  0.423529416f, 0.427450985f, 0.431372553f, 0.435294122f, 0.43921569f, 0.443137258f,
  0.447058827f, 0.450980395f, 0.454901963f, 0.458823532f, 0.4627451f, 0.466666669f,
  0.470588237f, 0.474509805f, 0.478431374f, 0.482352942f, 0.486274511f, 0.490196079f,
  0.494117647f, 0.498039216f, 0.501960814f, 0.505882382f, 0.509803951f, 0.513725519f,
  0.517647088f, 0.521568656f, 0.525490224f, 0.529411793f, 0.533333361f, 0.53725493f,
  0.541176498f, 0.545098066f, 0.549019635f, 0.552941203f, 0.556862772f, 0.56078434f,
  0.564705908f, 0.568627477f, 0.572549045f, 0.576470613f, 0.580392182f, 0.58431375f,
  0.588235319f, 0.592156887f, 0.596078455f, 0.600000024f, 0.603921592f, 0.607843161f,
  0.611764729f, 0.615686297f, 0.619607866f, 0.623529434f, 0.627451003f, 0.631372571f,
  0.635294139f, 0.639215708f, 0.643137276f, 0.647058845f, 0.650980413f, 0.654901981f,
  0.65882355f, 0.662745118f, 0.666666687f, 0.670588255f, 0.674509823f, 0.678431392f,
  0.68235296f, 0.686274529f, 0.690196097f, 0.694117665f, 0.698039234f, 0.701960802f,
  0.70588237f, 0.709803939f, 0.713725507f, 0.717647076f, 0.721568644f, 0.725490212f,
  0.729411781f, 0.733333349f, 0.737254918f, 0.741176486f, 0.745098054f, 0.749019623f,
  0.752941191f, 0.75686276f, 0.760784328f, 0.764705896f, 0.768627465f, 0.772549033f,
  0.776470602f, 0.78039217f, 0.784313738f, 0.788235307f, 0.792156875f, 0.796078444f,
  0.800000012f, 0.80392158f, 0.807843149f, 0.811764717f, 0.815686285f, 0.819607854f,
  0.823529422f, 0.827450991f, 0.831372559f, 0.835294127f, 0.839215696f, 0.843137264f,
  0.847058833f, 0.850980401f, 0.854901969f, 0.858823538f, 0.862745106f, 0.866666675f,
  0.870588243f, 0.874509811f, 0.87843138f, 0.882352948f, 0.886274517f, 0.890196085f,
  0.894117653f, 0.898039222f, 0.90196079f, 0.905882359f, 0.909803927f, 0.913725495f,
  0.917647064f, 0.921568632f, 0.925490201f, 0.929411769f, 0.933333337f, 0.937254906f,
  0.941176474f, 0.945098042f, 0.949019611f, 0.952941179f, 0.956862748f, 0.960784316f,
  0.964705884f, 0.968627453f, 0.972549021f, 0.97647059f, 0.980392158f, 0.984313726f,
  0.988235295f, 0.992156863f, 0.996078432f, 1.0f,
};

static const float srgb_table[256] = {
  0.0f, 0.000303526991f, 0.000607053982f, 0.000910580973f, 0.00121410796f, 0.00151763496f,
  0.00182116195f, 0.00212468882f, 0.00242821593f, 0.0027317428f, 0.00303526991f, 0.00334653584f,
  0.00367650739f, 0.00402471703f, 0.00439144205f, 0.00477695325f, 0.00518151652f, 0.00560539169f,
  0.00604883302f, 0.00651209056f, 0.00699541019f, 0.00749903219f, 0.00802319311f, 0.00856812578f,
  0.00913405884f, 0.00972121768f, 0.010329823f, 0.0109600937f, 0.0116122449f, 0.012286488f,
  0.0129830325f, 0.0137020834f, 0.0144438436f, 0.0152085144f, 0.0159962941f, 0.0168073755f,
  0.0176419541f, 0.01850022f, 0.0193823613f, 0.0202885624f, 0.0212190095f, 0.0221738853f,
  0.0231533665f, 0.0241576321f, 0.0251868591f, 0.0262412224f, 0.0273208916f, 0.02842604f,
  0.0295568351f, 0.0307134446f, 0.0318960324f, 0.0331047662f, 0.0343398079f, 0.0356013142f,
  0.0368894488f, 0.0382043719f, 0.0395462364f, 0.0409151986f, 0.0423114114f, 0.043735031f,
  0.045186203f, 0.0466650873f, 0.0481718257f, 0.0497065671f, 0.0512694567f, 0.0528606474f,
  0.054480277f, 0.0561284907f, 0.0578054301f, 0.0595112368f, 0.0612460524f, 0.0630100146f,
  0.064803265f, 0.0666259378f, 0.0684781671f, 0.0703600943f, 0.0722718537f, 0.0742135718f,
  0.0761853829f, 0.078187421f, 0.0802198201f, 0.0822827071f, 0.0843762085f, 0.0865004584f,
  0.0886555836f, 0.0908417106f, 0.0930589661f, 0.0953074694f, 0.097587347f, 0.0998987257f,
  0.102241732f, 0.104616486f, 0.107023105f, 0.10946171f, 0.111932427f, 0.114435375f,
  0.116970666f, 0.119538426f, 0.122138776f, 0.124771819f, 0.127437681f, 0.130136475f,
  0.13286832f, 0.135633335f, 0.138431609f, 0.141263291f, 0.144128472f, 0.147027269f,
  0.149959788f, 0.152926147f, 0.155926466f, 0.158960834f, 0.162029371f, 0.165132195f,
  0.168269396f, 0.171441108f, 0.174647406f, 0.177888423f, 0.18116425f, 0.18447499f,
  0.187820777f, 0.191201687f, 0.194617838f, 0.198069319f, 0.20155625f, 0.205078736f,
  0.208636865f, 0.212230757f, 0.215860501f, 0.219526201f, 0.223227963f, 0.226965874f,
  0.230740055f, 0.23455058f, 0.238397568f, 0.242281124f, 0.246201321f, 0.25015828f,
  0.254152089f, 0.258182853f, 0.262250662f, 0.266355604f, 0.270497799f, 0.274677306f,
  0.278894275f, 0.283148736f, 0.287440836f, 0.291770637f, 0.296138257f, 0.300543785f,
  0.304987311f, 0.309468925f, 0.313988715f, 0.318546772f, 0.323143214f, 0.327778101f,
  0.332451522f, 0.337163627f, 0.341914415f, 0.346704066f, 0.351532608f, 0.356400132f,
  0.361306787f, 0.366252601f, 0.371237695f, 0.376262128f, 0.38132602f, 0.386429429f,
  0.391572475f, 0.396755219f, 0.401977777f, 0.407240212f, 0.412542611f, 0.417885065f,
  0.423267663f, 0.428690493f, 0.434153646f, 0.439657182f, 0.445201188f, 0.450785786f,
  0.456411034f, 0.462076992f, 0.467783809f, 0.473531485f, 0.479320168f, 0.48514995f,
  0.491020858f, 0.496932983f, 0.502886474f, 0.50888133f, 0.514917672f, 0.520995557f,
  0.527115107f, 0.533276379f, 0.539479494f, 0.545724452f, 0.55201143f, 0.558340371f,
  0.564711511f, 0.571124852f, 0.577580452f, 0.584078431f, 0.590618849f, 0.597201765f,
  0.603827357f, 0.610495567f, 0.617206573f, 0.623960376f, 0.630757153f, 0.637596846f,
  0.644479692f, 0.651405632f, 0.658374846f, 0.665387273f, 0.672443151f, 0.679542482f,
  0.686685324f, 0.693871737f, 0.701101899f, 0.708375752f, 0.715693474f, 0.723055124f,
  0.730460763f, 0.73791039f, 0.745404184f, 0.752942204f, 0.760524511f, 0.768151164f,
  0.775822222f, 0.783537805f, 0.791297913f, 0.799102724f, 0.806952238f, 0.814846575f,
  0.822785735f, 0.830769897f, 0.838799f, 0.846873224f, 0.854992628f, 0.863157213f,
  0.871367097f, 0.8796224f, 0.887923121f, 0.896269381f, 0.904661179f, 0.913098633f,
  0.921581864f, 0.930110872f, 0.938685715f, 0.947306514f, 0.955973327f, 0.964686275f,
  0.973445296f, 0.982250571f, 0.991102099f, 1.0f,
};

/* ---- lookup: called at every textured hit, so no division, allocation or branch per
 * channel beyond the table choice ---- */

/* floorf(x) for finite x, as a truncation and a correction: the build targets baseline
 * x86-64, without SSE4.1's roundss, and GCC's own sequence for floorf there is longer, four
 * times a lookup (docs/BENCHMARKS.md, "The renderer's own rays replayed"). Floats of
 * magnitude 2^23 or more are integers already. The one difference, +0 for -0, changes no
 * coordinate or weight below. */
static inline float floor_finite(float x) {
  if (!(fabsf(x) < 0x1p23f)) return x;
  float t = (float)(int32_t)x;
  return t > x ? t - 1.0f : t;
}

/* Along one axis of n texels: the two texels the filter blends (i0 left of the sample,
 * i1 right of it) and the weight of i1. The coordinate is first brought into [0, 1] per
 * wrap mode, which also keeps huge coordinates from overflowing the index; the filter's
 * neighbour beyond an edge then wraps around (repeat) or is the edge texel (clamp, and
 * mirror, whose reflection repeats the edge texel). */
static inline void filter_axis(float s, int n, int wrap, int *i0, int *i1, float *weight) {
  if (wrap == VF_WRAP_REPEAT) {
    s -= floor_finite(s);
  } else if (wrap == VF_WRAP_MIRROR) {
    float m = s - 2.0f * floor_finite(0.5f * s); /* [0, 2]: period two, the second half reflected */
    s = m > 1.0f ? 2.0f - m : m;
  } else {
    s = s < 0.0f ? 0.0f : s > 1.0f ? 1.0f : s;
  }
  /* Texel i has its centre at i + 0.5. x is in [-0.5, n - 0.5], where truncation with a
   * step down below zero is floorf. */
  float x = s * (float)n - 0.5f;
  int a = (int)x;
  if ((float)a > x) a--;
  int b = a + 1; /* a in [-1, n - 1] */
  *weight = x - (float)a;
  if (wrap == VF_WRAP_REPEAT) {
    if (a < 0) a = n - 1;
    if (b >= n) b = 0;
  } else {
    if (a < 0) a = 0;
    if (b >= n) b = n - 1;
  }
  *i0 = a;
  *i1 = b;
}

/* Channel k of four 8-bit texels q[] decoded by `table` and blended with weights w[]. */
static inline float blend8(const float *table, const uint8_t *const q[4], int k, const float w[4]) {
  return w[0] * table[q[0][k]] + w[1] * table[q[1][k]] + w[2] * table[q[2][k]] + w[3] * table[q[3][k]];
}

/* The bilinear filter's four texels at (s, t_coord), as texel indices (row * width +
 * column) in the order 00, 10, 01, 11, and their weights in that order; non-finite
 * coordinates give texel (0, 0). Shared by the lookups and the prefetch, so that the
 * prefetch starts the loads of the very texels a lookup reads. */
static inline void footprint(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t, size_t texel[4],
                             float weight[4]) {
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  float fx = 0.0f, fy = 0.0f;
  if (isfinite(s) && isfinite(t_coord)) {
    filter_axis(s, (int)t->width, wrap_s, &x0, &x1, &fx);
    filter_axis(t_coord, (int)t->height, wrap_t, &y0, &y1, &fy);
  }
  const size_t w = t->width, r0 = (size_t)y0 * w, r1 = (size_t)y1 * w;
  texel[0] = r0 + (size_t)x0;
  texel[1] = r0 + (size_t)x1;
  texel[2] = r1 + (size_t)x0;
  texel[3] = r1 + (size_t)x1;
  weight[0] = (1.0f - fx) * (1.0f - fy);
  weight[1] = fx * (1.0f - fy);
  weight[2] = (1.0f - fx) * fy;
  weight[3] = fx * fy;
}

void vf_texture_lookup(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t, int srgb, float out[4]) {
  size_t i[4];
  float weight[4];
  footprint(t, s, t_coord, wrap_s, wrap_t, i, weight);
  const int n = t->channels;
  const size_t o00 = i[0] * (size_t)n, o10 = i[1] * (size_t)n, o01 = i[2] * (size_t)n, o11 = i[3] * (size_t)n;
  const float w00 = weight[0], w10 = weight[1], w01 = weight[2], w11 = weight[3];
  float v[4] = {0.0f, 0.0f, 0.0f, 1.0f};
  if (t->is_float) {
    const float *p = t->texels;
    for (int k = 0; k < n; k++) v[k] = w00 * p[o00 + k] + w10 * p[o10 + k] + w01 * p[o01 + k] + w11 * p[o11 + k];
  } else {
    /* Each texel is decoded before the blend: filtering happens on linear values. The
     * channel counts are spelled out, each channel's table chosen once rather than inside
     * a loop over n. */
    const uint8_t *p = t->texels;
    const float *colour = srgb ? srgb_table : linear_table; /* grey, or R, G, B; alpha is linear */
    const uint8_t *q[4] = {p + o00, p + o10, p + o01, p + o11};
    switch (n) {
    case 4: v[3] = blend8(linear_table, q, 3, weight); /* fall through */
    case 3:
      v[0] = blend8(colour, q, 0, weight);
      v[1] = blend8(colour, q, 1, weight);
      v[2] = blend8(colour, q, 2, weight);
      break;
    case 2: v[1] = blend8(linear_table, q, 1, weight); /* fall through */
    default: v[0] = blend8(colour, q, 0, weight);
    }
  }
  if (n < 3) { /* grey (and alpha) to RGB(A) */
    out[0] = out[1] = out[2] = v[0];
    out[3] = n == 2 ? v[1] : 1.0f;
  } else {
    out[0] = v[0];
    out[1] = v[1];
    out[2] = v[2];
    out[3] = n == 4 ? v[3] : 1.0f;
  }
}

void vf_texture_prefetch(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t) {
  size_t i[4];
  float weight[4];
  footprint(t, s, t_coord, wrap_s, wrap_t, i, weight);
  const size_t texel = (size_t)t->channels * (t->is_float ? sizeof(float) : 1u);
  const char *p = t->texels;
  /* The four texels; on one row, the two share a line but where a line ends. */
  for (int k = 0; k < 4; k++) __builtin_prefetch(p + i[k] * texel);
}

float vf_texture_lookup_channel(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t, int channel) {
  const int n = t->channels;
  /* Where the RGBA channel lives in the stored ones: grey is R, G and B; no alpha is 1. */
  int k = n >= 3 ? channel : channel < 3 ? 0 : 1;
  if (k >= n) return 1.0f;
  size_t i[4];
  float weight[4];
  footprint(t, s, t_coord, wrap_s, wrap_t, i, weight);
  const size_t o00 = i[0] * (size_t)n + (size_t)k, o10 = i[1] * (size_t)n + (size_t)k;
  const size_t o01 = i[2] * (size_t)n + (size_t)k, o11 = i[3] * (size_t)n + (size_t)k;
  const float w00 = weight[0], w10 = weight[1], w01 = weight[2], w11 = weight[3];
  if (t->is_float) {
    const float *p = t->texels;
    return w00 * p[o00] + w10 * p[o10] + w01 * p[o01] + w11 * p[o11];
  }
  const uint8_t *p = t->texels;
  return w00 * linear_table[p[o00]] + w10 * linear_table[p[o10]] + w01 * linear_table[p[o01]] +
         w11 * linear_table[p[o11]];
}
