import { describe, expect, it } from "vitest";
import { fieldsFromSchema } from "./schemaForm";
import type { JsonSchema } from "./jsonSchema";

const schema: JsonSchema = {
  properties: {
    amplitude: { type: "number", minimum: 0, maximum: 100, "x-soft": [0, 1] },
    frequency: { type: "number", minimum: 0, maximum: 50, "x-soft": [0, 5], "x-step": 0.05 },
    offset: { type: "number", "x-soft": [-1, 1] },
    sigma: { anyOf: [{ type: "number", exclusiveMinimum: 0, maximum: 1 }, { type: "null" }], default: null },
    delay: { type: "number" },
    count: { type: "integer", minimum: 1, maximum: 8 },
  },
};

describe("numbers from the schema (soft and hard ranges)", () => {
  const f = Object.fromEntries(fieldsFromSchema(schema).map((x) => [x.name, x]));
  it("puts the slider on the soft range and keeps the hard one for typing", () => {
    expect(f.amplitude.kind).toBe("slider");
    expect(f.amplitude.number).toMatchObject({ softMin: 0, softMax: 1, hardMin: 0, hardMax: 100, step: 0.01 });
    expect(f.frequency.number?.step).toBe(0.05);
    expect(f.offset.number).toMatchObject({ softMin: -1, softMax: 1, hardMin: undefined, hardMax: undefined });
  });
  it("uses a bounded hard range as the slider's when there is no soft one", () => {
    expect(f.sigma.kind).toBe("slider");
    expect(f.sigma.nullable).toBe(true);
    expect(f.sigma.number).toMatchObject({ softMin: 0, softMax: 1, hardMin: 0, minExclusive: true, hardMax: 1 });
    expect(f.count.number).toMatchObject({ softMin: 1, softMax: 8, step: 1, integer: true });
  });
  it("gives an unbounded number a text field only", () => {
    expect(f.delay.kind).toBe("number");
    expect(f.delay.number?.softMin).toBeUndefined();
  });
  it("gives a seed's enormous hard range a typed field, not a slider", () => {
    const [seed] = fieldsFromSchema({ properties: { seed: { type: "integer", minimum: 0, maximum: 2147483647, default: 0 } } });
    expect(seed.kind).toBe("integer");
    expect(seed.number).toMatchObject({ hardMin: 0, hardMax: 2147483647, step: 1 });
    expect(seed.number?.softMin).toBeUndefined();
  });
});
