/* Plays a golden artefact through the Sinew C API and prints every frame's hash in the format of
 * tests/data/NAME.hashes; exits non-zero if a frame differs from its recording or a call fails.
 *
 *   replay DATA_DIR NAME            e.g. replay tests/data aim-ict
 *   replay DATA_DIR NAME MODEL      e.g. replay tests/data fit-ict aim-ict
 *                                        replay tests/data motion-ict s2d-ict
 *
 * With two arguments NAME.sinew is the model: an AIM actor is played from
 * NAME.f32/q16/fast.replay.sinew (each frame hashed by sinew_aim_frame_hash and again from the
 * pose call of its mode), then each f32 frame's coefficients posed with the jaw they give alone
 * (sinew_aim_jaw_from_weights: the "jaw" lines), an S2D decoder from NAME.replay.sinew. With three, NAME.sinew is played
 * on MODEL.sinew: a fitted performance on its actor (frame hashes as `sinew fit` bakes them), or
 * a motion generator on its S2D decoder, generating the sequence NAME.hashes names (label, seed,
 * intensity) and decoding its frames. Build and run: core/ffi/run-example.sh (docs/C-API.md). */
#include "example.h"

static const char *MODE_NAMES[] = {"f32", "q16", "fast"};

/* A NaN in the head is refused in every mode, not guessed into a rotation: the status says so
 * even without an error record. Returns 1 if it is not refused. */
static int refuses_nan(const SinewModel *model, const SinewModelInfo *info, const char *what) {
    float head[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0}, jaw[9] = {1, 0, 0, 0, 1, 0, 0, 0, 0};
    head[3] = strtof("nan", NULL);
    float *weights = calloc(info->shape_count + 1, sizeof(float));
    float *scratch = calloc(info->scratch_floats, sizeof(float));
    int bad = weights == NULL || scratch == NULL;
    for (uint32_t m = 0; m < 3 && !bad; m++) {
        uint64_t hash = 0;
        SinewStatus status = sinew_aim_frame_hash(model, m, head, jaw, weights, info->shape_count,
                                                  scratch, info->scratch_floats, &hash, NULL);
        if (status != SINEW_STATUS_INVALID_INPUT) {
            fprintf(stderr, "%s: a NaN head in mode %s gave \"%s\", not a refusal\n", what,
                    MODE_NAMES[m], sinew_status_string((uint32_t)status));
            bad = 1;
        }
    }
    free(weights);
    free(scratch);
    return bad;
}

/* Poses one AIM frame with the pose call of `mode` (sinew_aim_pose, _q16, _fast) and hashes its
 * outputs (sinew_hash_frame, sinew_hash_q16): the frames an engine renders, whose hashes must be
 * the replay's. */
static SinewStatus pose_hash(const SinewModel *model, const SinewModelInfo *info, SinewMode mode,
                             const float *head, const float *jaw, const float *weights,
                             uint64_t *hash, SinewError *err) {
    size_t n = 3 * info->vertex_count;
    float *positions = malloc(n * sizeof(float));
    float *normals = malloc(n * sizeof(float));
    int32_t *fixed = malloc(n * sizeof(int32_t));
    SinewStatus status = SINEW_STATUS_INTERNAL;
    if (positions == NULL || normals == NULL || fixed == NULL) {
        fprintf(stderr, "out of memory\n");
    } else if (mode == SINEW_MODE_Q16) {
        status = sinew_aim_pose_q16(model, head, jaw, weights, info->shape_count, fixed, n, err);
        if (status == SINEW_STATUS_OK) {
            status = sinew_hash_q16(fixed, n, hash, err);
        }
    } else {
        status = mode == SINEW_MODE_FAST
                     ? sinew_aim_pose_fast(model, head, jaw, weights, info->shape_count,
                                           positions, n, normals, n, err)
                     : sinew_aim_pose(model, head, jaw, weights, info->shape_count, positions, n,
                                      normals, n, err);
        if (status == SINEW_STATUS_OK) {
            status = sinew_hash_frame(positions, n, normals, n, hash, err);
        }
    }
    free(positions);
    free(normals);
    free(fixed);
    return status;
}

/* Plays one replay file against an open model, printing "LABEL FRAME HASH" per frame. Returns the
 * number of differing frames, or -1 when something fails. */
static int play(const SinewModel *model, const SinewModelInfo *info, const char *path,
                const char *label) {
    SinewError err;
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return -1;
    }
    int bad = -1;
    SinewReplay *replay = NULL;
    SinewReplayInfo rinfo;
    float *scratch = calloc(info->scratch_floats, sizeof(float));
    float *weights = calloc(info->shape_count + 1, sizeof(float));
    float *input = calloc(info->input_len + 1, sizeof(float));
    float *neutral = NULL;
    float *vertices = calloc(3 * info->vertex_count, sizeof(float));
    if (scratch == NULL || weights == NULL || input == NULL || vertices == NULL) {
        fprintf(stderr, "%s: out of memory\n", path);
        goto done;
    }
    if (failed(sinew_replay_open(bytes, len, &replay, &err), &err, path) ||
        failed(sinew_replay_info(replay, &rinfo, &err), &err, path) ||
        failed(sinew_replay_check_model(replay, model, &err), &err, path)) {
        goto done;
    }
    if (rinfo.neutral_len > 0) {
        neutral = calloc(rinfo.neutral_len, sizeof(float));
        if (neutral == NULL ||
            failed(sinew_replay_s2d_neutral(replay, neutral, rinfo.neutral_len, &err), &err, path)) {
            goto done;
        }
    }
    bad = 0;
    for (size_t f = 0; f < rinfo.frame_count; f++) {
        uint64_t expected = 0, hash = 0;
        SinewStatus status;
        if (rinfo.kind == SINEW_KIND_AIM) {
            float head[9], jaw[9];
            status = sinew_replay_aim_frame(replay, f, head, jaw, weights, rinfo.shape_count,
                                            &expected, &err);
            if (status == SINEW_STATUS_OK) {
                status = sinew_aim_frame_hash(model, (uint32_t)rinfo.mode, head, jaw, weights,
                                              info->shape_count, scratch, info->scratch_floats,
                                              &hash, &err);
            }
            uint64_t posed = 0;
            if (status == SINEW_STATUS_OK) {
                status = pose_hash(model, info, rinfo.mode, head, jaw, weights, &posed, &err);
            }
            if (status == SINEW_STATUS_OK && posed != hash) {
                fprintf(stderr, "%s: frame %zu posed in mode %s hashes %016llx, not %016llx\n",
                        path, f, MODE_NAMES[rinfo.mode], (unsigned long long)posed,
                        (unsigned long long)hash);
                bad++;
            }
        } else {
            status = sinew_replay_s2d_frame(replay, f, input, rinfo.input_len, &expected, &err);
            if (status == SINEW_STATUS_OK) {
                status = sinew_s2d_decode(model, input, info->input_len, neutral,
                                          rinfo.neutral_len, scratch, info->scratch_floats,
                                          vertices, 3 * info->vertex_count, &hash, &err);
            }
        }
        if (failed(status, &err, path)) {
            bad = -1;
            goto done;
        }
        printf("%s %zu %016llx\n", label, f, (unsigned long long)hash);
        if (hash != expected) {
            fprintf(stderr, "%s: frame %zu is %016llx, recorded %016llx\n", path, f,
                    (unsigned long long)hash, (unsigned long long)expected);
            bad++;
        }
    }
done:
    sinew_replay_free(replay);
    free(bytes);
    free(scratch);
    free(weights);
    free(input);
    free(neutral);
    free(vertices);
    return bad;
}

/* Plays every frame of the fitted performance at `path` on the actor `model`, printing "FRAME
 * HASH" lines (tests/data/fit-ict.hashes); each hash is also compared with the one baked into
 * the file. Returns the number of differing frames, or -1 when something fails. */
static int play_performance(const SinewModel *model, const SinewModelInfo *info,
                            const char *path) {
    SinewError err;
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return -1;
    }
    int bad = -1;
    SinewPerformance *perf = NULL;
    SinewPerformanceInfo pinfo;
    float *scratch = NULL;
    size_t n = 3 * info->vertex_count;
    float *positions = malloc(n * sizeof(float));
    float *normals = malloc(n * sizeof(float));
    if (positions == NULL || normals == NULL ||
        failed(sinew_performance_open(bytes, len, &perf, &err), &err, path) ||
        failed(sinew_performance_info(perf, &pinfo, &err), &err, path) ||
        failed(sinew_performance_check_model(perf, model, &err), &err, path)) {
        goto done;
    }
    scratch = calloc(pinfo.scratch_floats, sizeof(float));
    if (scratch == NULL) {
        goto done;
    }
    printf("# %s: %zu frames, %s coefficients; per frame: the f32 hash of positions then "
           "normals\n",
           path, pinfo.frame_count, pinfo.is_local ? "local" : "global");
    bad = 0;
    for (size_t f = 0; f < pinfo.frame_count; f++) {
        uint64_t hash = 0, baked = 0;
        if (failed(sinew_performance_pose(perf, model, f, scratch, pinfo.scratch_floats,
                                          positions, n, normals, n, &hash, &err),
                   &err, path)) {
            bad = -1;
            goto done;
        }
        printf("%zu %016llx\n", f, (unsigned long long)hash);
        if (pinfo.has_hashes &&
            (failed(sinew_performance_expected(perf, f, &baked, &err), &err, path) ||
             baked != hash)) {
            fprintf(stderr, "%s: frame %zu is %016llx, baked %016llx\n", path, f,
                    (unsigned long long)hash, (unsigned long long)baked);
            bad++;
        }
    }
done:
    sinew_performance_free(perf);
    free(bytes);
    free(scratch);
    free(positions);
    free(normals);
    return bad;
}

/* Reads the "sequence NAME LABEL SEED INTENSITY" line of the hash list at `path`, keeping the
 * seed and intensity as written, to be printed back. Returns 0 on success. */
static int read_sequence(const char *path, char *name, size_t *label, unsigned long long *seed,
                         char *seed_text, char *intensity_text) {
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        fprintf(stderr, "%s: cannot open\n", path);
        return 1;
    }
    char line[512];
    int found = 1;
    while (found != 0 && fgets(line, sizeof line, f) != NULL) {
        if (sscanf(line, "sequence %63s %zu %31s %31s", name, label, seed_text,
                   intensity_text) == 4) {
            *seed = strtoull(seed_text, NULL, 10);
            found = 0;
        }
    }
    fclose(f);
    if (found != 0) {
        fprintf(stderr, "%s: no \"sequence NAME LABEL SEED INTENSITY\" line\n", path);
    }
    return found;
}

/* Generates the sequence the hash list `list` names with the generator at `path` on the S2D
 * decoder `decoder` (onto its template), printing the list's "sequence" line and a "motion T
 * HASH" line per frame. Returns 0, or -1 when something fails. */
static int play_motion(const SinewModel *decoder, const char *path, const char *list) {
    char name[64], seed_text[32], intensity_text[32], label_name[64];
    size_t label = 0;
    unsigned long long seed = 0;
    if (read_sequence(list, name, &label, &seed, seed_text, intensity_text) != 0) {
        return -1;
    }
    SinewError err;
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return -1;
    }
    int result = -1;
    SinewSequence *sequence = NULL;
    SinewSequenceInfo sinfo;
    float *curve = NULL, *scratch = NULL, *vertices = NULL;
    if (failed(sinew_sequence_open(bytes, len, decoder, &sequence, &err), &err, path) ||
        failed(sinew_sequence_info(sequence, &sinfo, &err), &err, path) ||
        failed(sinew_sequence_label_name(sequence, label, label_name, sizeof label_name, NULL,
                                         &err),
               &err, path)) {
        goto done;
    }
    if (strcmp(label_name, name) != 0) {
        fprintf(stderr, "%s: label %zu is %s, the list says %s\n", path, label, label_name, name);
        goto done;
    }
    curve = calloc(sinfo.curve_floats, sizeof(float));
    scratch = calloc(sinfo.scratch_floats, sizeof(float));
    vertices = calloc(3 * sinfo.vertex_count, sizeof(float));
    if (curve == NULL || scratch == NULL || vertices == NULL ||
        failed(sinew_sequence_curve(sequence, label, (uint64_t)seed,
                                    strtof(intensity_text, NULL), NULL, 0, curve,
                                    sinfo.curve_floats, scratch, sinfo.scratch_floats, &err),
               &err, path)) {
        goto done;
    }
    printf("# %s: %zu landmarks through the decoder (%zu vertices) onto its template; per frame "
           "1 to %zu: the decoded vertices (f32 bits)\n",
           path, sinfo.landmark_count, sinfo.vertex_count, sinfo.frame_count);
    printf("sequence %s %zu %s %s\n", label_name, label, seed_text, intensity_text);
    for (size_t t = 1; t <= sinfo.frame_count; t++) {
        uint64_t hash = 0;
        if (failed(sinew_sequence_frame(sequence, t, curve, sinfo.curve_floats, NULL, 0, scratch,
                                        sinfo.scratch_floats, vertices, 3 * sinfo.vertex_count,
                                        &hash, &err),
                   &err, path)) {
            goto done;
        }
        printf("motion %zu %016llx\n", t, (unsigned long long)hash);
    }
    result = 0;
done:
    sinew_sequence_free(sequence);
    free(bytes);
    free(curve);
    free(scratch);
    free(vertices);
    return result;
}

/* The "jaw" lines of an AIM hash list: for each frame of the f32 replay at `path`, the hash of
 * the jaw its coefficients give alone (sinew_aim_jaw_from_weights), then the f32 frame hash of
 * the frame's head, that jaw and the coefficients. Returns 0, or -1 when a call fails. */
static int play_jaw(const SinewModel *model, const SinewModelInfo *info, const char *path) {
    SinewError err;
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return -1;
    }
    int bad = -1;
    SinewReplay *replay = NULL;
    SinewReplayInfo rinfo;
    float *scratch = calloc(info->scratch_floats, sizeof(float));
    float *weights = calloc(info->shape_count + 1, sizeof(float));
    if (scratch == NULL || weights == NULL) {
        fprintf(stderr, "%s: out of memory\n", path);
        goto done;
    }
    if (failed(sinew_replay_open(bytes, len, &replay, &err), &err, path) ||
        failed(sinew_replay_info(replay, &rinfo, &err), &err, path)) {
        goto done;
    }
    printf("# jaw: per frame, the hash of jaw_from_weights(coefficients), then the f32 frame hash "
           "with that jaw\n");
    for (size_t f = 0; f < rinfo.frame_count; f++) {
        float head[9], recorded_jaw[9], jaw[9];
        uint64_t expected = 0, jaw_hash = 0, hash = 0;
        if (failed(sinew_replay_aim_frame(replay, f, head, recorded_jaw, weights,
                                          rinfo.shape_count, &expected, &err),
                   &err, path) ||
            failed(sinew_aim_jaw_from_weights(model, weights, info->shape_count, jaw, &err), &err,
                   path) ||
            failed(sinew_hash_frame(jaw, 9, NULL, 0, &jaw_hash, &err), &err, path) ||
            failed(sinew_aim_frame_hash(model, SINEW_MODE_F32, head, jaw, weights,
                                        info->shape_count, scratch, info->scratch_floats, &hash,
                                        &err),
                   &err, path)) {
            goto done;
        }
        printf("jaw %zu %016llx %016llx\n", f, (unsigned long long)jaw_hash,
               (unsigned long long)hash);
    }
    bad = 0;
done:
    sinew_replay_free(replay);
    free(bytes);
    free(scratch);
    free(weights);
    return bad;
}

int main(int argc, char **argv) {
    if (argc != 3 && argc != 4) {
        fprintf(stderr,
                "usage: %s DATA_DIR NAME [MODEL] (e.g. tests/data aim-ict; tests/data fit-ict "
                "aim-ict; tests/data motion-ict s2d-ict)\n",
                argv[0]);
        return 2;
    }
    /* The header this program was compiled with must describe the library it runs with. */
    if (sinew_abi_version() != SINEW_ABI_VERSION) {
        fprintf(stderr, "libsinew %s has ABI %u, this program was built for ABI %u\n",
                sinew_version(), (unsigned)sinew_abi_version(), (unsigned)SINEW_ABI_VERSION);
        return 1;
    }
    const char *dir = argv[1], *name = argv[2];
    char path[4096];
    snprintf(path, sizeof path, "%s/%s.sinew", dir, argc == 4 ? argv[3] : name);
    size_t len = 0;
    uint8_t *bytes = read_file(path, &len);
    if (bytes == NULL) {
        return 1;
    }
    SinewError err;
    SinewModel *model = NULL;
    SinewModelInfo info;
    if (failed(sinew_model_open(bytes, len, &model, &err), &err, path) ||
        failed(sinew_model_info(model, &info, &err), &err, path)) {
        sinew_model_free(model);
        free(bytes);
        return 1;
    }
    int bad = 0;
    if (argc == 4) {
        char list[4096];
        snprintf(path, sizeof path, "%s/%s.sinew", dir, name);
        snprintf(list, sizeof list, "%s/%s.hashes", dir, name);
        bad = info.kind == SINEW_KIND_AIM ? play_performance(model, &info, path)
                                          : play_motion(model, path, list);
    } else if (info.kind == SINEW_KIND_AIM) {
        printf("# %s.sinew: %zu vertices, %zu shapes; per mode and frame: f32/fast hash positions "
               "then normals, q16 the positions' raw bits\n",
               name, info.vertex_count, info.shape_count);
        for (int m = 0; m < 3 && bad >= 0; m++) {
            snprintf(path, sizeof path, "%s/%s.%s.replay.sinew", dir, name, MODE_NAMES[m]);
            int r = play(model, &info, path, MODE_NAMES[m]);
            bad = r < 0 ? r : bad + r;
        }
        if (bad >= 0) {
            snprintf(path, sizeof path, "%s/%s.f32.replay.sinew", dir, name);
            if (play_jaw(model, &info, path) < 0) {
                bad = -1;
            }
        }
        if (bad >= 0 && refuses_nan(model, &info, name)) {
            bad = -1;
        }
    } else {
        printf("# %s.sinew: %zu vertices, %zu inputs, %zu scratch values; per frame: the decoded "
               "vertices (f32 bits), decoded onto the replay's neutral\n",
               name, info.vertex_count, info.input_len, info.scratch_floats);
        snprintf(path, sizeof path, "%s/%s.replay.sinew", dir, name);
        bad = play(model, &info, path, "s2d");
    }
    sinew_model_free(model);
    free(bytes);
    if (bad != 0) {
        fprintf(stderr, "%s: %s\n", name, bad < 0 ? "failed" : "frames differ from the recording");
        return 1;
    }
    return 0;
}
