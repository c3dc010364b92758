/* Test plugin (plain C, as a third party would write one): returns invalid
 * detections on purpose so the host's validation can be checked.
 * config: "mode: garbage" | "mode: fail" | "mode: overflow" | "mode: negative_count"
 * | "mode: create_fail". */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sitepose/detect/plugin_abi.h"

#define EXPORT __attribute__((visibility("default")))

struct sp_detector {
  int mode; /* 0 garbage, 1 fail, 2 overflow, 3 negative count */
};

static void set_err(char* err, size_t errlen, const char* msg) {
  if (err != NULL && errlen > 0) {
    strncpy(err, msg, errlen - 1);
    err[errlen - 1] = '\0';
  }
}

static sp_detection det(const char* name, float score, int x, int y, int w, int h, uint16_t id) {
  sp_detection d;
  memset(&d, 0, sizeof(d));
  strncpy(d.class_name, name, SP_CLASS_NAME_LEN - 1);
  d.score = score;
  d.x = x;
  d.y = y;
  d.w = w;
  d.h = h;
  d.instance = id;
  return d;
}

EXPORT uint32_t sitepose_detector_abi_version(void) { return SITEPOSE_DETECTOR_ABI_VERSION; }

EXPORT sp_detector* sitepose_detector_create(const char* config, char* err, size_t errlen) {
  sp_detector* h = (sp_detector*)calloc(1, sizeof(sp_detector));
  if (config != NULL && strstr(config, "create_fail") != NULL) {
    free(h);
    set_err(err, errlen, "garbage plugin refuses to start");
    return NULL;
  }
  if (config != NULL && strstr(config, "negative_count") != NULL) h->mode = 3;
  else if (config != NULL && strstr(config, "overflow") != NULL) h->mode = 2;
  else if (config != NULL && strstr(config, "fail") != NULL) h->mode = 1;
  return h;
}

EXPORT uint32_t sitepose_detector_capabilities(const sp_detector* handle) {
  (void)handle;
  return SP_DETECTOR_CAP_SEGMENTATION;
}

EXPORT int sitepose_detector_detect(sp_detector* handle, const sp_image* left,
                                    const sp_image* right, int64_t t_ns, int64_t seq,
                                    sp_detection* out, int32_t capacity, int32_t* count,
                                    char* err, size_t errlen) {
  (void)right;
  (void)t_ns;
  if (handle->mode == 1) {
    set_err(err, errlen, "simulated failure");
    return 1;
  }
  if (handle->mode == 3) {
    *count = -5;
    return 0;
  }
  const int W = left->width, H = left->height;
  sp_detection all[12];
  int n = 0;
  all[n++] = det("truck", 0.9f, 10, 10, 20, 20, 1);           /* valid */
  all[n++] = det("truck", NAN, 10, 10, 20, 20, 2);            /* NaN score */
  all[n++] = det("truck", -0.5f, 10, 10, 20, 20, 3);          /* negative score */
  all[n++] = det("truck", INFINITY, 10, 10, 20, 20, 4);       /* infinite score */
  all[n++] = det("truck", 0.8f, W + 5, 10, 20, 20, 5);        /* entirely outside */
  all[n++] = det("roller", 0.7f, W - 10, H - 10, 50, 50, 6);  /* partly outside: clipped */
  all[n++] = det("truck", 0.8f, 10, 10, 0, 20, 7);            /* zero width */
  all[n++] = det("truck", 0.8f, 10, 10, 20, 20, 0);           /* instance 0 */
  all[n++] = det("truck", 0.8f, 40, 40, 10, 10, 1);           /* duplicate instance */
  all[n] = det("truck", 0.8f, 0, 0, 5, 5, 9);                 /* unterminated name */
  memset(all[n].class_name, 'x', SP_CLASS_NAME_LEN);
  ++n;
  all[n++] = det("truck", 2.5f, 2147483600, 0, 2147483600, 5, 10); /* overflowing corners */
  all[n++] = det("", 0.5f, 0, 0, 5, 5, 11);                   /* empty name */
  (void)seq;
  int total = n;
  if (handle->mode == 2) total = capacity + 7; /* more than the host's array */
  for (int i = 0; i < n && i < capacity; ++i) out[i] = all[i];
  *count = total;
  return 0;
}

EXPORT int sitepose_detector_segment(sp_detector* handle, const sp_image* left,
                                     const sp_image* right, int64_t t_ns, int64_t seq,
                                     const sp_detection* detections, int32_t n_detections,
                                     uint16_t* mask, int32_t mask_stride_px, char* err,
                                     size_t errlen) {
  (void)right;
  (void)t_ns;
  (void)seq;
  (void)detections;
  (void)n_detections;
  if (handle->mode == 1) {
    set_err(err, errlen, "simulated segment failure");
    return 1;
  }
  /* Fill the whole image with id 1 (only its box may survive) and a stripe of an unknown id. */
  for (int v = 0; v < left->height; ++v) {
    for (int u = 0; u < left->width; ++u) mask[v * mask_stride_px + u] = (v < 2) ? 77 : 1;
  }
  return 0;
}

EXPORT void sitepose_detector_destroy(sp_detector* handle) { free(handle); }
