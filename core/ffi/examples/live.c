/* Drives an actor live from a real tracker's track through the Sinew C API, with the calibration
 * and the lost-frame rules (sinew_live_step), as an engine would from a webcam, and prints every
 * frame's outcome and hashes in the format of tests/data/LIST.hashes; exits non-zero if a call
 * fails or a refusal the API promises does not come.
 *
 *   live DATA_DIR LIST DRIVER MODEL      e.g. live tests/data driver-ict-live driver-ict aim-ict
 *
 * The hash list LIST.hashes names the track (an OpenFace 2.0 CSV in DATA_DIR) with the camera's
 * intrinsics ("track FILE FX FY CX CY") and the live settings ("live CALIBRATE_FRAMES
 * MAX_RESIDUAL MAX_SPEED MAX_TURN REACQUIRE"). Per CSV row: the pixels through the intrinsics
 * (sinew_driver_pixels; none when the row's success is 0), one live step at the row's time stamp
 * (sinew_live_step: the pose to play and the outcome), the posed frame (sinew_driver_play).
 * Printed: the two header lines, then "outcome F NAME", "pose F HASH" and "frame F HASH" for
 * every frame. Build and run: core/ffi/run-example.sh (docs/C-API.md). */
#include "track.h"

static const char *outcome_name(SinewLiveOutcome o) {
    switch (o) {
    case SINEW_LIVE_OUTCOME_DRIVEN:
        return "driven";
    case SINEW_LIVE_OUTCOME_CALIBRATING:
        return "calibrating";
    case SINEW_LIVE_OUTCOME_MISSING:
        return "missing";
    case SINEW_LIVE_OUTCOME_LOST_RESIDUAL:
        return "lost-residual";
    case SINEW_LIVE_OUTCOME_LOST_JUMP:
        return "lost-jump";
    }
    return "?";
}

/* The hash list's "track" and "live" lines. */
static int read_list(const char *path, char *track, size_t track_len, SinewIntrinsics *camera,
                     SinewLive *live) {
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
        } else if (sscanf(line, "live %u %f %f %f %f", &live->calibrate_frames, &live->max_residual,
                          &live->max_speed, &live->max_turn, &live->reacquire) == 5) {
            found |= 2;
        }
    }
    fclose(f);
    if (found != 3) {
        fprintf(stderr, "%s: no \"track\" or \"live\" line\n", path);
        return 1;
    }
    return 0;
}

/* A time stamp that does not move on is refused, naming it, and the state is kept. Returns 1 if
 * not. */
static int refuses_a_stale_time(const SinewDriver *driver, const SinewModel *model,
                                const SinewLive *live, float time, float *state, size_t state_len,
                                float *scratch, size_t scratch_len, float *pose, size_t pose_len) {
    SinewError err;
    float kept = state[0];
    SinewStatus status = sinew_live_step(driver, model, live, NULL, 0, time, state, state_len,
                                         scratch, scratch_len, pose, pose_len, NULL, &err);
    if (status != SINEW_STATUS_INVALID_INPUT || strncmp(err.message, "time[0]", 7) != 0 ||
        state[0] != kept) {
        fprintf(stderr, "a repeated time stamp gave \"%s\", not a refusal naming time[0]\n",
                err.message);
        return 1;
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr,
                "usage: %s DATA_DIR LIST DRIVER MODEL (e.g. tests/data driver-ict-live driver-ict "
                "aim-ict)\n",
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
    SinewLive live;
    snprintf(path, sizeof path, "%s/%s.hashes", argv[1], argv[2]);
    if (read_list(path, track, sizeof track, &camera, &live) != 0) {
        return 1;
    }
    static float times[MAX_ROWS], pixels[MAX_ROWS][2 * LANDMARKS];
    static int found[MAX_ROWS];
    snprintf(path, sizeof path, "%s/%s", argv[1], track);
    int rows = read_track(path, times, found, pixels);
    if (rows < 0) {
        return 1;
    }
    size_t model_len = 0, driver_len = 0;
    snprintf(path, sizeof path, "%s/%s.sinew", argv[1], argv[4]);
    uint8_t *model_bytes = read_file(path, &model_len);
    snprintf(path, sizeof path, "%s/%s.sinew", argv[1], argv[3]);
    uint8_t *driver_bytes = read_file(path, &driver_len);
    SinewError err;
    SinewModel *model = NULL;
    SinewDriver *driver = NULL;
    SinewDriverInfo info;
    SinewLiveInfo live_info;
    int bad = model_bytes == NULL || driver_bytes == NULL;
    bad = bad || failed(sinew_model_open(model_bytes, model_len, &model, &err), &err, argv[4]);
    bad = bad ||
          failed(sinew_driver_open(driver_bytes, driver_len, model, &driver, &err), &err, argv[3]);
    bad = bad || failed(sinew_driver_info(driver, &info, &err), &err, "info");
    bad = bad || failed(sinew_live_info(driver, model, &live_info, &err), &err, "live info");
    float *landmarks = NULL, *scratch = NULL, *pose = NULL, *state = NULL, *positions = NULL,
          *normals = NULL;
    if (!bad) {
        landmarks = malloc(info.input_len * sizeof(float));
        scratch = malloc(live_info.scratch_floats * sizeof(float));
        pose = malloc(info.pose_len * sizeof(float));
        state = calloc(live_info.state_floats, sizeof(float)); /* zeros: nothing seen yet */
        positions = malloc(3 * info.vertex_count * sizeof(float));
        normals = malloc(3 * info.vertex_count * sizeof(float));
        bad = !landmarks || !scratch || !pose || !state || !positions || !normals;
        if (info.landmark_dims != 2) {
            fprintf(stderr, "%s: a 3D driver; the track is 2D pixels\n", argv[3]);
            bad = 1;
        }
    }
    static SinewLiveOutcome outcomes[MAX_ROWS];
    static uint64_t hashes[MAX_ROWS][2];
    for (int f = 0; f < rows && !bad; f++) {
        /* A row without a face is a step without landmarks: the last pose holds. */
        const float *seen = NULL;
        if (found[f]) {
            bad = failed(sinew_driver_pixels(pixels[f], 2 * LANDMARKS, &camera, landmarks,
                                             info.input_len, &err),
                         &err, "pixels");
            seen = landmarks;
        }
        bad = bad ||
              failed(sinew_live_step(driver, model, &live, seen, seen ? info.input_len : 0,
                                     times[f], state, live_info.state_floats, scratch,
                                     live_info.scratch_floats, pose, info.pose_len, &outcomes[f],
                                     &err),
                     &err, "live step") ||
              failed(sinew_hash_frame(pose, info.pose_len, NULL, 0, &hashes[f][0], &err), &err,
                     "hash") ||
              failed(sinew_driver_play(driver, model, pose, info.pose_len, positions,
                                       3 * info.vertex_count, normals, 3 * info.vertex_count,
                                       &hashes[f][1], &err),
                     &err, "play");
    }
    bad = bad || rows == 0 ||
          refuses_a_stale_time(driver, model, &live, times[rows - 1], state,
                               live_info.state_floats, scratch, live_info.scratch_floats, pose,
                               info.pose_len);
    if (!bad) {
        printf("track %s %g %g %g %g\n", track, camera.fx, camera.fy, camera.cx, camera.cy);
        printf("live %u %g %g %g %g\n", live.calibrate_frames, live.max_residual, live.max_speed,
               live.max_turn, live.reacquire);
        for (int f = 0; f < rows; f++) {
            printf("outcome %d %s\n", f, outcome_name(outcomes[f]));
        }
        for (int k = 0; k < 2; k++) {
            for (int f = 0; f < rows; f++) {
                printf("%s %d %016llx\n", k == 0 ? "pose" : "frame", f,
                       (unsigned long long)hashes[f][k]);
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
