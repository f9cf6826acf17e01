// Times WireLib (Pott, part of WireX; built outside this repository by
// build.sh) on the poses `cargo bench --bench cpp_reference` writes, with the
// protocol of that bench: the median time per call over the 1000 poses x 20
// rounds, each call timed. This file is our harness; no code of WireLib is
// copied here, only its public classes are called.
//
//   wirelib_bench POSES_FILE           timing rows, "name<TAB>median ns"
//   wirelib_bench POSES_FILE check     WireLib's results beside ours
//   wirelib_bench_allocations POSES_FILE allocations
//                                      heap allocations per call (the same
//                                      source built with
//                                      WIRELIB_BENCH_COUNT_ALLOCATIONS, which
//                                      counts every malloc, calloc and
//                                      realloc; the timing build counts none)
//
// Conventions: WireLib's structure equation is A^T f + w = 0 (w the wrench
// applied to the platform), ours W t = f (f the wrench the cables must
// produce); the structure matrix A^T is our W (columns [u_i; (R b_i) x u_i],
// u_i the unit vector from the platform towards the anchor), so WireLib's w
// is our -f. The rotation of a pose is R = Rx(rx) Ry(ry) Rz(rz), built with
// WireLib's own Matrix3d::XRotationMatrix3d etc.
//
// The force distributions of CForceDistribution read the structure matrix of
// the last getStructureMatrix call, so each timed distribution call is
// preceded, outside the timed interval, by getStructureMatrix at its pose.

#include <WireLib/RobotData.h>
#include <WireLib/StructureMatrix.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace PCRL;

#ifdef WIRELIB_BENCH_COUNT_ALLOCATIONS
// Every heap allocation of the process goes through these (libstdc++'s
// operator new calls malloc; Eigen calls malloc); they count and pass on to
// glibc's allocator.
extern "C" void* __libc_malloc(size_t);
extern "C" void* __libc_calloc(size_t, size_t);
extern "C" void* __libc_realloc(void*, size_t);
static unsigned long long heap_allocations = 0;
extern "C" void* malloc(size_t size) {
    ++heap_allocations;
    return __libc_malloc(size);
}
extern "C" void* calloc(size_t count, size_t size) {
    ++heap_allocations;
    return __libc_calloc(count, size);
}
extern "C" void* realloc(void* old, size_t size) {
    ++heap_allocations;
    return __libc_realloc(old, size);
}
#endif

namespace {

const int kRounds = 20;
const int kDof = 6;

// One record of the poses file: the pose, its rotation and WireLib's w.
struct Pose {
    Vector3d position;
    Matrix3d rotation;
    double angles[3];
    MatrixXd wrench;  // WireLib's w = -f
};

// What the Rust bench wrote: the robot, the poses, our matrices and tensions.
struct PosesFile {
    std::vector<Vector3d> anchors, attachments;
    std::vector<double> t_min, t_max;
    std::vector<Pose> poses;
    std::vector<MatrixXd> our_matrices;
    // (method name, pose) -> (status, tensions)
    std::map<std::pair<std::string, int>, std::pair<std::string, std::vector<double>>> our_tensions;
};

Matrix3d rotation_of(double rx, double ry, double rz) {
    return Matrix3d::XRotationMatrix3d(rx) * Matrix3d::YRotationMatrix3d(ry) * Matrix3d::ZRotationMatrix3d(rz);
}

PosesFile read_poses(const char* path) {
    std::ifstream in(path);
    if (!in) {
        std::fprintf(stderr, "%s: cannot open\n", path);
        std::exit(2);
    }
    PosesFile file;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string kind;
        words >> kind;
        if (kind == "cable") {
            int i;
            double x[8];
            words >> i;
            for (double& v : x) words >> v;
            file.anchors.push_back(Vector3d(x[0], x[1], x[2]));
            file.attachments.push_back(Vector3d(x[3], x[4], x[5]));
            file.t_min.push_back(x[6]);
            file.t_max.push_back(x[7]);
        } else if (kind == "pose") {
            int k;
            double x[12];
            words >> k;
            for (double& v : x) words >> v;
            Pose pose;
            pose.position = Vector3d(x[0], x[1], x[2]);
            std::copy(x + 3, x + 6, pose.angles);
            pose.rotation = rotation_of(x[3], x[4], x[5]);
            pose.wrench.resize(kDof, 1);
            for (int i = 0; i < kDof; i++) pose.wrench(i) = -x[6 + i];
            file.poses.push_back(pose);
        } else if (kind == "matrix") {
            int k;
            words >> k;
            MatrixXd w(kDof, file.anchors.size());
            for (int r = 0; r < w.rows(); r++)
                for (int c = 0; c < w.cols(); c++) words >> w(r, c);
            file.our_matrices.push_back(w);
        } else if (kind == "tensions") {
            std::string method, status;
            int k;
            words >> method >> k >> status;
            std::vector<double> t;
            double v;
            while (words >> v) t.push_back(v);
            file.our_tensions[std::make_pair(method, k)] = std::make_pair(status, t);
        }
        if (!kind.empty() && kind[0] != '#' && words.fail() && kind != "tensions") {
            std::fprintf(stderr, "%s: cannot read line: %s\n", path, line.c_str());
            std::exit(2);
        }
    }
    if (file.anchors.empty() || file.poses.empty()) {
        std::fprintf(stderr, "%s: no cables or no poses\n", path);
        std::exit(2);
    }
    for (size_t i = 0; i < file.t_min.size(); i++)
        if (file.t_min[i] != file.t_min[0] || file.t_max[i] != file.t_max[0]) {
            // WireLib's robot has one pair of limits (CRobotData::fmin, fmax),
            // which its barycenter reads.
            std::fprintf(stderr, "%s: per-cable limits differ; WireLib takes one pair\n", path);
            std::exit(2);
        }
    return file;
}

// A WireLib robot with the file's geometry and limits, and its force
// distribution object (which holds the structure matrix).
struct Reference {
    CRobotData robot;
    CForceDistribution distribution;
    MatrixXd f_min, f_max;  // the limits as WireLib's methods take them

    explicit Reference(const PosesFile& file)
        : robot(file.anchors.size(), CRobotData::MP3R3T), distribution(robot) {
        const int cables = file.anchors.size();
        for (int i = 0; i < cables; i++) {
            robot.setBase(i, file.anchors[i]);
            robot.setPlatform(i, file.attachments[i]);
        }
        robot.setForceLimits(file.t_min[0], file.t_max[0]);
        f_min = MatrixXd::Constant(cables, 1, file.t_min[0]);
        f_max = MatrixXd::Constant(cables, 1, file.t_max[0]);
    }
};

// A timed call: its name, the untimed preparation before each call, the call.
struct Call {
    std::string name;
    std::function<void(int)> prepare;
    std::function<bool(int)> run;
};

volatile double sink;  // keeps results alive

// The timed calls. They capture pointers (by value) to `ref`, `file` and
// `tensions`, which outlive them.
std::vector<Call> calls(Reference& ref, PosesFile& file, MatrixXd& tensions) {
    // Scratch the methods write into, sized once; WireLib's puncture shrinks
    // the limits it is given by 1e-6 in place, so it gets fresh copies.
    static MatrixXd punct_min, punct_max;
    static int vertices;
    static double area;
    punct_min = ref.f_min;
    punct_max = ref.f_max;
    tensions = MatrixXd::Zero(file.anchors.size(), 1);
    Reference* r = &ref;
    MatrixXd* t = &tensions;
    std::vector<Pose>* poses = &file.poses;  // WireLib takes w by non-const reference
    CForceDistribution* fd = &ref.distribution;
    auto structure_matrix = [=](int k) { fd->getStructureMatrix((*poses)[k].position, (*poses)[k].rotation); };
    auto nothing = [](int) {};
    // The structure matrix at pose k and the linear solver of the closed form.
    auto with_solver = [=](emLinearSolverMethod::Type solver) {
        return [=](int k) {
            structure_matrix(k);
            fd->setLinearSolver(solver);
        };
    };
    auto closed_form = [=](int k) {
        return fd->getDistributionClosedForm((*poses)[k].wrench, r->f_min, r->f_max, *t);
    };
    std::vector<Call> all;
    // What the timing itself costs (two clock reads), in every row.
    all.push_back({"timer (empty call)", nothing, [](int k) { return k >= 0; }});
    all.push_back({"kinematics", nothing, [=](int k) {
                       const Pose& p = (*poses)[k];
                       Matrix3d R = rotation_of(p.angles[0], p.angles[1], p.angles[2]);
                       return fd->getStructureMatrix(p.position, R);
                   }});
    all.push_back({"kinematics (given R)", nothing,
                   [=](int k) { return fd->getStructureMatrix((*poses)[k].position, (*poses)[k].rotation); }});
    all.push_back({"closed-form (llt, default)", with_solver(emLinearSolverMethod::llt), closed_form});
    all.push_back({"closed-form (lu)", with_solver(emLinearSolverMethod::lu), closed_form});
    all.push_back({"closed-form (householderQr)", with_solver(emLinearSolverMethod::householderQr), closed_form});
    all.push_back({"improved-closed-form", with_solver(emLinearSolverMethod::llt), [=](int k) {
                       return fd->getDistributionAdvancedClosedForm((*poses)[k].wrench, r->f_min, r->f_max, *t);
                   }});
    all.push_back({"puncture",
                   [=](int k) {
                       structure_matrix(k);
                       fd->setLinearSolver(emLinearSolverMethod::llt);
                       punct_min = r->f_min;  // same size: no allocation
                       punct_max = r->f_max;
                       // WireLib's puncture applies the 1e-6 only over the
                       // entries its output already has.
                       if (t->size() != r->f_min.size()) *t = r->f_min;
                   },
                   [=](int k) { return fd->getDistributionPuncture((*poses)[k].wrench, punct_min, punct_max, *t); }});
    all.push_back({"barycenter", structure_matrix, [=](int k) {
                       return fd->getDistributionBarycenter((*poses)[k].wrench, r->f_min, r->f_max, *t, vertices,
                                                            area);
                   }});
    return all;
}

double median_ns(Call& call, int poses) {
    std::vector<long long> times;
    times.reserve((size_t)kRounds * poses);
    for (int round = 0; round < kRounds; round++)
        for (int k = 0; k < poses; k++) {
            call.prepare(k);
            auto start = std::chrono::steady_clock::now();
            bool ok = call.run(k);
            auto stop = std::chrono::steady_clock::now();
            sink = ok;
            times.push_back(std::chrono::duration_cast<std::chrono::nanoseconds>(stop - start).count());
        }
    std::sort(times.begin(), times.end());
    return (double)times[times.size() / 2];
}

// max_i |a_i - b_i| / max_i |b_i|
double relative_difference(const MatrixXd& ours, const MatrixXd& theirs) {
    return (theirs - ours).cwiseAbs().maxCoeff() / ours.cwiseAbs().maxCoeff();
}

bool within(const MatrixXd& t, const MatrixXd& lo, const MatrixXd& hi, double slack) {
    for (int i = 0; i < t.size(); i++)
        if (!(t(i) >= lo(i) - slack && t(i) <= hi(i) + slack)) return false;
    return true;
}

// WireLib's results beside ours: the structure matrix at every pose, and the
// tensions of the methods both have.
void check(Reference& ref, PosesFile& file) {
    MatrixXd tensions;
    std::vector<Call> all = calls(ref, file, tensions);
    const int poses = file.poses.size(), cables = file.anchors.size();
    double matrix_diff = 0;
    for (int k = 0; k < poses && k < (int)file.our_matrices.size(); k++) {
        ref.distribution.getStructureMatrix(file.poses[k].position, file.poses[k].rotation);
        MatrixXd at;
        ref.distribution.getMatrix(at);
        matrix_diff = std::max(matrix_diff, (at - file.our_matrices[k]).cwiseAbs().maxCoeff());
    }
    std::printf("structure matrix A^T vs our W: max |difference| over %d poses %.3g\n", poses, matrix_diff);

    // WireLib's call -> our methods it is compared with.
    const char* pairs[][2] = {
        {"closed-form (llt, default)", "closed-form"},
        {"closed-form (lu)", "closed-form"},
        {"closed-form (householderQr)", "closed-form"},
        {"improved-closed-form", "improved-closed-form"},
        {"puncture", "puncture"},
        {"puncture", "improved-puncture"},
        {"barycenter", "barycenter"},
    };
    const int shown[] = {0, 250, 500, 750};
    for (auto& pair : pairs) {
        Call* call = nullptr;
        for (Call& c : all)
            if (c.name == pair[0]) call = &c;
        int both_ok = 0, over_1e6 = 0;
        int ours_failed = 0, ours_failed_theirs_bad = 0;    // ours failed; WireLib false or out of limits
        int theirs_failed = 0, theirs_outside = 0;          // where ours solved
        double worst = 0;
        int worst_pose = -1;
        std::string shown_rows;
        for (int k = 0; k < poses; k++) {
            call->prepare(k);
            bool ok = call->run(k);
            bool feasible = ok && tensions.size() == cables && within(tensions, ref.f_min, ref.f_max, 1e-9);
            auto found = file.our_tensions.find(std::make_pair(std::string(pair[1]), k));
            if (found == file.our_tensions.end()) continue;
            if (found->second.first != "ok") {
                ours_failed++;
                if (!feasible) ours_failed_theirs_bad++;
                continue;
            }
            if (!ok) {
                theirs_failed++;
                continue;
            }
            if (!feasible) theirs_outside++;
            MatrixXd ours(cables, 1);
            for (int i = 0; i < cables; i++) ours(i) = found->second.second[i];
            double d = relative_difference(ours, tensions);
            both_ok++;
            if (d > 1e-6) over_1e6++;
            if (d > worst) worst = d, worst_pose = k;
            if (std::find(std::begin(shown), std::end(shown), k) != std::end(shown)) {
                char buf[512];
                std::string a, b;
                for (int i = 0; i < cables; i++) {
                    std::snprintf(buf, sizeof buf, " %9.6f", ours(i));
                    a += buf;
                    std::snprintf(buf, sizeof buf, " %9.6f", tensions(i));
                    b += buf;
                }
                std::snprintf(buf, sizeof buf, "    pose %4d ours   %s\n    pose %4d WireLib%s  (rel. diff %.2e)\n", k,
                              a.c_str(), k, b.c_str(), d);
                shown_rows += buf;
            }
        }
        std::printf(
            "\nWireLib %s vs our %s: both solved %d poses: max relative difference %.3g (pose %d), %d above 1e-6;\n"
            "  where ours solved, WireLib failed at %d and left the limits at %d; ours failed at %d poses, WireLib "
            "failed or left the limits at %d of them\n%s",
            pair[0], pair[1], both_ok, worst, worst_pose, over_1e6, theirs_failed, theirs_outside, ours_failed,
            ours_failed_theirs_bad, shown_rows.c_str());
    }
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s POSES_FILE [check|allocations]\n", argv[0]);
        return 2;
    }
    PosesFile file = read_poses(argv[1]);
    Reference ref(file);
    std::string mode = argc > 2 ? argv[2] : "";
    if (mode == "check") {
        check(ref, file);
        return 0;
    }
    MatrixXd tensions;
    std::vector<Call> all = calls(ref, file, tensions);
    const int poses = file.poses.size();
    if (mode == "allocations") {
#ifdef WIRELIB_BENCH_COUNT_ALLOCATIONS
        for (Call& call : all) {
            unsigned long long total = 0;
            for (int k = 0; k < poses; k++) {
                call.prepare(k);
                unsigned long long before = heap_allocations;
                call.run(k);
                total += heap_allocations - before;
            }
            std::printf("%s\t%.1f\n", call.name.c_str(), (double)total / poses);
        }
        return 0;
#else
        std::fprintf(stderr, "allocations: build with -DWIRELIB_BENCH_COUNT_ALLOCATIONS (build.sh does)\n");
        return 2;
#endif
    }
    for (Call& call : all) std::printf("%s\t%.0f\n", call.name.c_str(), median_ns(call, poses));
    return 0;
}
