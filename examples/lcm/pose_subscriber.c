/* Receives siteposed's poses over LCM with the generated C types
 * (sitepose-dev: /usr/include/sitepose/sitepose_pose_t.h and
 * libsitepose_lcmtypes.a) and prints one line per pose. Build against the
 * installed package:
 *   cc pose_subscriber.c -o pose_subscriber -lsitepose_lcmtypes -llcm
 * Usage: pose_subscriber [--count N] [--url URL] [--channel NAME]
 * (as pose_subscriber.cpp). */

#include <lcm/lcm.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sitepose/sitepose_pose_t.h>

static long received = 0;

static void on_pose(const lcm_recv_buf_t* rbuf, const char* channel, const sitepose_pose_t* m, void* user) {
  (void)rbuf;
  (void)channel;
  (void)user;
  printf(
      "pose seq=%lld utime=%lld state=%d frame=%d position=%.6f,%.6f,%.6f "
      "orientation=%.6f,%.6f,%.6f,%.6f velocity=%.6f,%.6f,%.6f lat=%.9f lon=%.9f height=%.4f "
      "heading=%.4f position_std=%.6f\n",
      (long long)m->seq, (long long)m->utime, m->state, m->frame, m->position[0], m->position[1],
      m->position[2], m->orientation[0], m->orientation[1], m->orientation[2], m->orientation[3],
      m->velocity[0], m->velocity[1], m->velocity[2], m->latitude_deg, m->longitude_deg, m->height_m,
      m->heading_deg, m->position_std_m);
  fflush(stdout);
  ++received;
}

int main(int argc, char** argv) {
  const char* url = NULL;
  const char* channel = "SITEPOSE_POSE";
  long limit = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (strcmp(argv[i], "--count") == 0) {
      limit = atol(argv[i + 1]);
    } else if (strcmp(argv[i], "--url") == 0) {
      url = argv[i + 1];
    } else if (strcmp(argv[i], "--channel") == 0) {
      channel = argv[i + 1];
    } else {
      fprintf(stderr, "usage: %s [--count N] [--url URL] [--channel NAME]\n", argv[0]);
      return 2;
    }
  }
  lcm_t* lcm = lcm_create(url);
  if (lcm == NULL) {
    fprintf(stderr, "cannot open LCM %s\n", url ? url : "(default URL)");
    return 1;
  }
  sitepose_pose_t_subscribe(lcm, channel, on_pose, NULL);
  int status = 0;
  while (limit == 0 || received < limit) {
    if (lcm_handle(lcm) != 0) {
      status = 1;
      break;
    }
  }
  lcm_destroy(lcm);
  return status;
}
