#include "settings.h"

#include "error.h"

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const algorithm_names[VF_ALGO_COUNT_] = {"vcm", "bpt", "pt", "lt", "ppm", "bpm", "auto", "upg", "auto-unbiased"};
static const char *const sampler_names[VF_SAMPLER_COUNT_] = {"independent", "sobol"};

void vf_settings_default(vf_settings *s) {
  s->algorithm = VF_ALGO_VCM;
  s->max_path_length = 10;
  s->radius_factor = 0.003;
  s->alpha = 0.75;
  s->seed = 1;
  s->width = 512;
  s->height = 512;
  s->sampler = VF_SAMPLER_SOBOL;
  s->mis_beta = 1.0;
  s->gather = VF_GATHER_LIGHT;
  s->radius = VF_RADIUS_GLOBAL;
  s->vcm_stages = 2;
  s->light_path_pixels = 1;
  s->pilot = 0;
}

const char *vf_sampler_name(vf_sampler_kind k) {
  return (unsigned)k < VF_SAMPLER_COUNT_ ? sampler_names[k] : "unknown";
}

/* The index of name in names[0 .. count), or -1. */
static int name_index(const char *const *names, int count, const char *name) {
  for (int i = 0; i < count; i++)
    if (strcmp(name, names[i]) == 0) return i;
  return -1;
}

int vf_sampler_parse(const char *name, vf_sampler_kind *out) {
  int i = name_index(sampler_names, VF_SAMPLER_COUNT_, name);
  if (i < 0) return vf_error_set(VF_EUSAGE, "unknown sampler '%s' (expected independent or sobol)", name);
  *out = (vf_sampler_kind)i;
  return VF_OK;
}

const char *vf_algorithm_name(vf_algorithm a) {
  return (unsigned)a < VF_ALGO_COUNT_ ? algorithm_names[a] : "unknown";
}

int vf_algorithm_parse(const char *name, vf_algorithm *out) {
  int i = name_index(algorithm_names, VF_ALGO_COUNT_, name);
  if (i >= 0) {
    *out = (vf_algorithm)i;
    return VF_OK;
  }
  return vf_error_set(VF_EUSAGE, "unknown algorithm '%s' (expected vcm, upg, bpt, pt, lt, ppm, bpm, auto or auto-unbiased)", name);
}

vf_estimate_scope vf_algorithm_estimate_scope(vf_algorithm a) {
  switch (a) {
  case VF_ALGO_VCM:
  case VF_ALGO_PPM:
  case VF_ALGO_BPM: return VF_ESTIMATE_VARIANCE;
  case VF_ALGO_AUTO: return VF_ESTIMATE_DEPENDS;
  case VF_ALGO_AUTO_UNBIASED: return VF_ESTIMATE_ERROR;
  default: return VF_ESTIMATE_ERROR;
  }
}

const char *vf_estimate_scope_name(vf_estimate_scope scope) {
  switch (scope) {
  case VF_ESTIMATE_ERROR: return "error";
  case VF_ESTIMATE_VARIANCE: return "variance";
  default: return "error or variance";
  }
}

static const char *const gather_names[VF_GATHER_COUNT_] = {"light", "camera", "auto"};

const char *vf_gather_name(vf_gather_side g) { return (unsigned)g < VF_GATHER_COUNT_ ? gather_names[g] : "unknown"; }

int vf_gather_parse(const char *name, vf_gather_side *out) {
  int i = name_index(gather_names, VF_GATHER_COUNT_, name);
  if (i >= 0) {
    *out = (vf_gather_side)i;
    return VF_OK;
  }
  return vf_error_set(VF_EUSAGE, "unknown side '%s' to gather from (expected light, camera or auto)", name);
}

static const char *const radius_names[VF_RADIUS_COUNT_] = {"global", "per-pixel"};

const char *vf_radius_mode_name(vf_radius_mode m) { return (unsigned)m < VF_RADIUS_COUNT_ ? radius_names[m] : "unknown"; }

int vf_radius_mode_parse(const char *name, vf_radius_mode *out) {
  int i = name_index(radius_names, VF_RADIUS_COUNT_, name);
  if (i >= 0) {
    *out = (vf_radius_mode)i;
    return VF_OK;
  }
  return vf_error_set(VF_EUSAGE, "unknown merge radius '%s' (expected global or per-pixel)", name);
}

int vf_algorithm_merges(vf_algorithm a) {
  return a == VF_ALGO_VCM || a == VF_ALGO_UPG || a == VF_ALGO_PPM || a == VF_ALGO_BPM || vf_algorithm_is_auto(a);
}

int vf_settings_validate(const vf_settings *s) {
  if ((unsigned)s->algorithm >= VF_ALGO_COUNT_) return vf_error_set(VF_EINVAL, "unknown algorithm");
  if ((unsigned)s->sampler >= VF_SAMPLER_COUNT_) return vf_error_set(VF_EINVAL, "unknown sampler");
  if (s->max_path_length < 1 || s->max_path_length > VF_MAX_PATH_LENGTH)
    return vf_error_set(VF_EINVAL, "max path length %d is outside [1, %d]", s->max_path_length, VF_MAX_PATH_LENGTH);
  if (!(s->radius_factor > 0.0) || !isfinite(s->radius_factor))
    return vf_error_set(VF_EINVAL, "radius factor %g must be a positive number", s->radius_factor);
  if (!(s->alpha > 0.0 && s->alpha <= 1.0))
    return vf_error_set(VF_EINVAL, "alpha %g is outside (0, 1]", s->alpha);
  if ((unsigned)s->gather >= VF_GATHER_COUNT_) return vf_error_set(VF_EINVAL, "unknown side to gather from");
  if (s->gather != VF_GATHER_LIGHT && s->algorithm != VF_ALGO_UPG)
    return vf_error_set(VF_EINVAL, "gathering from the %s's side is an option of upg, not of %s", vf_gather_name(s->gather),
                        vf_algorithm_name(s->algorithm));
  if ((unsigned)s->radius >= VF_RADIUS_COUNT_) return vf_error_set(VF_EINVAL, "unknown merge radius");
  if (s->radius != VF_RADIUS_GLOBAL && !vf_algorithm_merges(s->algorithm))
    return vf_error_set(VF_EINVAL, "a merge radius per pixel is an option of the algorithms that merge (vcm, upg, ppm, "
                        "bpm, auto), not of %s", vf_algorithm_name(s->algorithm));
  if (!(s->mis_beta >= 1.0 && s->mis_beta <= VF_MAX_MIS_BETA))
    return vf_error_set(VF_EINVAL, "MIS beta %g is outside [1, %g]", s->mis_beta, VF_MAX_MIS_BETA);
  if (s->vcm_stages != 1 && s->vcm_stages != 2)
    return vf_error_set(VF_EINVAL, "vcm stages %d: 1 (single-stage) or 2 (two-stage)", s->vcm_stages);
  if (s->vcm_stages == 1 && s->algorithm != VF_ALGO_VCM && s->algorithm != VF_ALGO_AUTO)
    return vf_error_set(VF_EINVAL, "the single-stage iteration (vcm stages 1) is an option of vcm (and of auto when it "
                        "chooses vcm), not of %s", vf_algorithm_name(s->algorithm));
  if (s->light_path_pixels < 1 || s->light_path_pixels > VF_MAX_LIGHT_PATH_PIXELS ||
      (s->light_path_pixels & (s->light_path_pixels - 1)) != 0)
    return vf_error_set(VF_EINVAL, "light path pixels %d: a power of two from 1 to %d", s->light_path_pixels,
                        VF_MAX_LIGHT_PATH_PIXELS);
  if (s->light_path_pixels != 1 && (s->algorithm == VF_ALGO_PT || s->algorithm == VF_ALGO_UPG))
    return vf_error_set(VF_EINVAL, "pixels sharing a light sub-path (light path pixels %d) is an option of the "
                        "algorithms with light sub-paths but upg (vcm, bpt, lt, ppm, bpm, auto), not of %s",
                        s->light_path_pixels, vf_algorithm_name(s->algorithm));
  if (s->pilot < 0 || s->pilot == 1 || s->pilot > VF_MAX_PILOT)
    return vf_error_set(VF_EINVAL, "pilot of %d iterations: 0 (none) or 2 to %d", s->pilot, VF_MAX_PILOT);
  if (s->pilot != 0 && s->algorithm != VF_ALGO_PT && s->algorithm != VF_ALGO_BPT && s->algorithm != VF_ALGO_VCM &&
      s->algorithm != VF_ALGO_AUTO)
    return vf_error_set(VF_EINVAL, "a pilot (camera sub-paths allocated per pixel) is an option of pt, bpt, vcm and "
                        "auto, not of %s", vf_algorithm_name(s->algorithm));
  if (s->pilot != 0 && s->vcm_stages != 2)
    return vf_error_set(VF_EINVAL, "a pilot (camera sub-paths allocated per pixel) is an option of the two-stage "
                        "iteration, not of the single-stage one (vcm stages 1)");
  if (s->width < 1 || s->height < 1 || s->width > VF_MAX_IMAGE_SIDE || s->height > VF_MAX_IMAGE_SIDE ||
      (int64_t)s->width * s->height > (int64_t)1 << 28)
    return vf_error_set(VF_EINVAL, "resolution %dx%d is outside 1x1 .. 65536x65536 (at most 2^28 pixels)",
                        s->width, s->height);
  return VF_OK;
}

void vf_double_format(double v, char *buf, size_t n) {
  /* The fewest significant digits that read back as the same double: unique for each
   * value, so the text stays canonical; %.17g always round-trips. */
  for (int digits = 1; digits <= 17; digits++) {
    snprintf(buf, n, "%.*g", digits, v);
    if (strtod(buf, NULL) == v) return;
  }
}

int vf_settings_format(const vf_settings *s, char *buf, size_t n) {
  char radius[32], alpha[32];
  vf_double_format(s->radius_factor, radius, sizeof radius);
  vf_double_format(s->alpha, alpha, sizeof alpha);
  int w = snprintf(buf, n, "algorithm=%s max_path_length=%d radius_factor=%s alpha=%s seed=%" PRIu64 " resolution=%dx%d",
                   vf_algorithm_name(s->algorithm), s->max_path_length, radius, alpha, s->seed, s->width, s->height);
  if (w >= 0 && (size_t)w < n && s->sampler != VF_SAMPLER_INDEPENDENT)
    w += snprintf(buf + w, n - (size_t)w, " sampler=%s", vf_sampler_name(s->sampler));
  if (w >= 0 && (size_t)w < n && s->mis_beta != 1.0) {
    char beta[32];
    vf_double_format(s->mis_beta, beta, sizeof beta);
    w += snprintf(buf + w, n - (size_t)w, " mis_beta=%s", beta);
  }
  if (w >= 0 && (size_t)w < n && s->gather != VF_GATHER_LIGHT)
    w += snprintf(buf + w, n - (size_t)w, " gather=%s", vf_gather_name(s->gather));
  if (w >= 0 && (size_t)w < n && s->radius != VF_RADIUS_GLOBAL)
    w += snprintf(buf + w, n - (size_t)w, " radius=%s", vf_radius_mode_name(s->radius));
  if (w >= 0 && (size_t)w < n && s->vcm_stages != 2) w += snprintf(buf + w, n - (size_t)w, " vcm_stages=%d", s->vcm_stages);
  if (w >= 0 && (size_t)w < n && s->light_path_pixels != 1)
    w += snprintf(buf + w, n - (size_t)w, " light_path_pixels=%d", s->light_path_pixels);
  if (w >= 0 && (size_t)w < n && s->pilot != 0) w += snprintf(buf + w, n - (size_t)w, " pilot=%d", s->pilot);
  if (w < 0 || (size_t)w >= n) return vf_error_set(VF_EINVAL, "settings text too long");
  return VF_OK;
}

int vf_settings_parse(vf_settings *s, const char *text) {
  vf_settings out;
  vf_settings_default(&out);
  out.sampler = VF_SAMPLER_INDEPENDENT; /* what a text without one was rendered with */
  unsigned seen = 0;
  char key[64], value[128];
  const char *p = text;
  int used;
  while (sscanf(p, " %63[^=]=%127s%n", key, value, &used) == 2) {
    char *end = NULL;
    if (strcmp(key, "algorithm") == 0) {
      if (vf_algorithm_parse(value, &out.algorithm) != VF_OK) goto bad;
      seen |= 1;
    } else if (strcmp(key, "max_path_length") == 0) {
      out.max_path_length = (int)strtol(value, &end, 10);
      seen |= 2;
    } else if (strcmp(key, "radius_factor") == 0) {
      out.radius_factor = strtod(value, &end);
      seen |= 4;
    } else if (strcmp(key, "alpha") == 0) {
      out.alpha = strtod(value, &end);
      seen |= 8;
    } else if (strcmp(key, "seed") == 0) {
      out.seed = strtoull(value, &end, 10);
      seen |= 16;
    } else if (strcmp(key, "resolution") == 0) {
      if (sscanf(value, "%dx%d", &out.width, &out.height) != 2) goto bad;
      seen |= 32;
    } else if (strcmp(key, "sampler") == 0) {
      if (seen & 64 || vf_sampler_parse(value, &out.sampler) != VF_OK) goto bad;
      seen |= 64;
    } else if (strcmp(key, "mis_beta") == 0) {
      if (seen & 128) goto bad;
      out.mis_beta = strtod(value, &end);
      seen |= 128;
    } else if (strcmp(key, "gather") == 0) {
      if (seen & 256 || vf_gather_parse(value, &out.gather) != VF_OK) goto bad;
      seen |= 256;
    } else if (strcmp(key, "radius") == 0) {
      if (seen & 512 || vf_radius_mode_parse(value, &out.radius) != VF_OK) goto bad;
      seen |= 512;
    } else if (strcmp(key, "vcm_stages") == 0) {
      if (seen & 1024) goto bad;
      out.vcm_stages = (int)strtol(value, &end, 10);
      seen |= 1024;
    } else if (strcmp(key, "light_path_pixels") == 0) {
      if (seen & 2048) goto bad;
      long pixels = strtol(value, &end, 10);
      out.light_path_pixels = pixels >= 1 && pixels <= VF_MAX_LIGHT_PATH_PIXELS ? (int)pixels : 0;
      seen |= 2048;
    } else if (strcmp(key, "pilot") == 0) {
      if (seen & 4096) goto bad;
      long pilot = strtol(value, &end, 10);
      out.pilot = pilot >= 1 && pilot <= VF_MAX_PILOT ? (int)pilot : -1;
      seen |= 4096;
    } else {
      return vf_error_set(VF_EINVAL, "settings: unknown key '%s'", key);
    }
    if (end != NULL && *end != '\0') goto bad;
    p += used;
  }
  while (*p == ' ') p++;
  if (*p != '\0' || (seen & 63) != 63) return vf_error_set(VF_EINVAL, "settings: malformed or incomplete text \"%.60s\"", text);
  int err = vf_settings_validate(&out);
  if (err != VF_OK) return err;
  *s = out;
  return VF_OK;
bad:
  return vf_error_set(VF_EINVAL, "settings: bad value '%s' for '%s'", value, key);
}

int vf_settings_canonicalize(char *text, size_t n) {
  vf_settings s;
  char canonical[512];
  int err = vf_settings_parse(&s, text);
  if (err == VF_OK) err = vf_settings_format(&s, canonical, sizeof canonical);
  if (err == VF_OK && strlen(canonical) >= n) err = vf_error_set(VF_EINVAL, "settings text too long");
  if (err == VF_OK) memcpy(text, canonical, strlen(canonical) + 1);
  return err;
}
