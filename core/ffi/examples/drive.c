/* Drives an actor live through the Sinew C API, as an engine would from a webcam tracker, and
 * prints every frame's hashes in the format of tests/data/NAME.hashes; exits non-zero if a call
 * fails or a refusal the API promises does not come.
 *
 *   drive DATA_DIR NAME MODEL      e.g. drive tests/data driver-ict aim-ict
 *
 * NAME.sinew is a landmark driver of the actor MODEL.sinew. The hash list NAME.hashes names the
 * track (an OpenFace 2.0 CSV in DATA_DIR) with the camera's intrinsics ("track FILE FX FY CX CY")
 * and the One Euro filter's settings ("filter MIN_CUTOFF BETA D_CUTOFF"). Per CSV row: the pixels
 * through the intrinsics (sinew_driver_pixels), the pose (sinew_driver_pose), the posed frame
 * (sinew_driver_play); then the same pose filtered at the row's time stamp (sinew_driver_filter)
 * and posed. Printed: the two header lines, then "pose F HASH", "frame F HASH",
 * "filtered-pose F HASH" and "filtered-frame F HASH" for every frame. Build and run:
 * core/ffi/run-example.sh (docs/C-API.md). */
#include "track.h"

/* The hash list's "track" and "filter" lines. */
static int read_list(const char *path, char *track, size_t track_len, SinewIntrinsics *camera,
                     SinewFilter *filter) {
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open\n", path);
        return 1;
    }
    char line[512], name[256];
    int found = 0;
    while (fgets(line, sizeof line, f) != NULL) {
        if (sscanf(line, "track %255s %f %f %f %f", name, &camera->fx, &camera->fy, &camera->cx,
                   &camera->cy) == 5 &&
            strlen(name) < track_len) {
            strcpy(track, name);
            found |= 1;
        } else if (sscanf(line, "filter %f %f %f", &filter->min_cutoff, &filter->beta,
                          &filter->d_cutoff) == 3) {
            found |= 2;
        }
    }
    fclose(f);
    if (found != 3) {
        fprintf(stderr, "%s: no \"track\" or \"filter\" line\n", path);
        return 1;
    }
    return 0;
}

/* A NaN landmark is refused, naming it, and nothing is written. Returns 1 if not. */
static int refuses_nan(const SinewDriver *driver, const SinewDriverInfo *info, float *landmarks,
                       float *scratch, float *pose) {
    SinewError err;
    float kept = landmarks[17];
    landmarks[17] = strtof("nan", NULL);
    pose[0] = 7.0f;
    SinewStatus status = sinew_driver_pose(driver, landmarks, info->input_len, scratch,
                                           info->scratch_floats, pose, info->pose_len, &err);
    landmarks[17] = kept;
    if (status != SINEW_STATUS_INVALID_INPUT || strcmp(err.message, "landmarks[17] is NaN or infinite") != 0 ||
        pose[0] != 7.0f) {
        fprintf(stderr, "a NaN landmark gave \"%s\", not a refusal naming landmarks[17]\n",
                err.message);
        return 1;
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: %s DATA_DIR DRIVER MODEL (e.g. tests/data driver-ict aim-ict)\n",
                argv[0]);
        return 2;
    }
    if (sinew_abi_version() != SINEW_ABI_VERSION) {
        fprintf(stderr, "libsinew's ABI %u is not the header's %u\n", sinew_abi_version(),
                SINEW_ABI_VERSION);
        return 1;
    }
    char path[1024], track[256];
    SinewIntrinsics camera;
    SinewFilter filter;
    snprintf(path, sizeof path, "%s/%s.hashes", argv[1], argv[2]);
    if (read_list(path, track, sizeof track, &camera, &filter) != 0) {
        return 1;
    }
    static float times[MAX_ROWS], pixels[MAX_ROWS][2 * LANDMARKS];
    snprintf(path, sizeof path, "%s/%s", argv[1], track);
    int rows = read_track(path, times, NULL, pixels);
    if (rows < 0) {
        return 1;
    }
    size_t model_len = 0, driver_len = 0;
    snprintf(path, sizeof path, "%s/%s.sinew", argv[1], argv[3]);
    uint8_t *model_bytes = read_file(path, &model_len);
    snprintf(path, sizeof path, "%s/%s.sinew", argv[1], argv[2]);
    uint8_t *driver_bytes = read_file(path, &driver_len);
    SinewError err;
    SinewModel *model = NULL;
    SinewDriver *driver = NULL;
    SinewDriverInfo info;
    int bad = model_bytes == NULL || driver_bytes == NULL;
    bad = bad || failed(sinew_model_open(model_bytes, model_len, &model, &err), &err, argv[3]);
    bad = bad ||
          failed(sinew_driver_open(driver_bytes, driver_len, model, &driver, &err), &err, argv[2]);
    bad = bad || failed(sinew_driver_info(driver, &info, &err), &err, "info");
    float *landmarks = NULL, *scratch = NULL, *pose = NULL, *state = NULL, *positions = NULL,
          *normals = NULL;
    if (!bad) {
        landmarks = malloc(info.input_len * sizeof(float));
        scratch = malloc(info.scratch_floats * sizeof(float));
        pose = malloc(info.pose_len * sizeof(float));
        state = calloc(info.filter_state_floats, sizeof(float)); /* zeros: a reset filter */
        positions = malloc(3 * info.vertex_count * sizeof(float));
        normals = malloc(3 * info.vertex_count * sizeof(float));
        bad = !landmarks || !scratch || !pose || !state || !positions || !normals;
        if (info.landmark_dims != 2) {
            fprintf(stderr, "%s: a 3D driver; the track is 2D pixels\n", argv[2]);
            bad = 1;
        }
    }
    /* Per frame, in order: pose, frame, filtered-pose, filtered-frame. */
    static uint64_t hashes[MAX_ROWS][4];
    for (int f = 0; f < rows && !bad; f++) {
        uint64_t h[4];
        bad = failed(sinew_driver_pixels(pixels[f], 2 * LANDMARKS, &camera, landmarks,
                                         info.input_len, &err),
                     &err, "pixels") ||
              failed(sinew_driver_pose(driver, landmarks, info.input_len, scratch,
                                       info.scratch_floats, pose, info.pose_len, &err),
                     &err, "pose") ||
              failed(sinew_hash_frame(pose, info.pose_len, NULL, 0, &h[0], &err), &err, "hash") ||
              failed(sinew_driver_play(driver, model, pose, info.pose_len, positions,
                                       3 * info.vertex_count, normals, 3 * info.vertex_count,
                                       &h[1], &err),
                     &err, "play") ||
              failed(sinew_driver_filter(driver, &filter, times[f], state,
                                         info.filter_state_floats, pose, info.pose_len, &err),
                     &err, "filter") ||
              failed(sinew_hash_frame(pose, info.pose_len, NULL, 0, &h[2], &err), &err, "hash") ||
              failed(sinew_driver_play(driver, model, pose, info.pose_len, positions,
                                       3 * info.vertex_count, normals, 3 * info.vertex_count,
                                       &h[3], &err),
                     &err, "play");
        memcpy(hashes[f], h, sizeof h);
    }
    bad = bad || refuses_nan(driver, &info, landmarks, scratch, pose);
    if (!bad) {
        static const char *KINDS[] = {"pose", "frame", "filtered-pose", "filtered-frame"};
        printf("track %s %g %g %g %g\n", track, camera.fx, camera.fy, camera.cx, camera.cy);
        printf("filter %g %g %g\n", filter.min_cutoff, filter.beta, filter.d_cutoff);
        for (int k = 0; k < 4; k++) {
            for (int f = 0; f < rows; f++) {
                printf("%s %d %016llx\n", KINDS[k], f, (unsigned long long)hashes[f][k]);
            }
        }
    }
    free(landmarks);
    free(scratch);
    free(pose);
    free(state);
    free(positions);
    free(normals);
    sinew_driver_free(driver);
    sinew_model_free(model);
    free(driver_bytes);
    free(model_bytes);
    return bad;
}
