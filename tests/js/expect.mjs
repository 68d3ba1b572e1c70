// Failure collection shared by the readers' checks: fail(what) records a failure;
// expectEq / expectNear compare a value read with the one expected.
export function checker() {
    const failures = [];
    const fail = (what) => failures.push(what);
    const expectEq = (what, got, want) => {
        if (got !== want) fail(`${what}: expected ${want}, got ${got}`);
    };
    const expectNear = (what, got, want, tol) => {
        if (!(Math.abs(got - want) <= tol)) fail(`${what}: expected ${want} ± ${tol}, got ${got}`);
    };
    return { failures, fail, expectEq, expectNear };
}
