// A chain of DEPTH registers of W bits with one load enable per register (box_unit's pipeline stages).
// Register j takes the value before it (d for j = 0) when load[j] is high and holds it otherwise. No reset:
// the valid bits that say whether a register holds an item live in the instantiating module.
module pipe_delay #(
    parameter int W     = 1,
    parameter int DEPTH = 1
) (
    input  logic             clk,
    input  logic [DEPTH-1:0] load,
    input  logic [    W-1:0] d,
    output logic [    W-1:0] q
);
  logic [W-1:0] r[DEPTH];

  always_ff @(posedge clk) begin
    if (load[0]) r[0] <= d;
    for (int j = 1; j < DEPTH; j++) if (load[j]) r[j] <= r[j-1];
  end

  assign q = r[DEPTH-1];
endmodule
