within Inchworm;
package Mechanics "The stack's finite elements, the flexure, the environment spring, the brakes' clamps and the runner (docs/model.md sections 2.2, 2.3, 2.5)"
  model Fixed "A flange fixed at s0"
    parameter Types.Position s0 = 0 "Position";
    Interfaces.Flange flange;
  equation
    flange.s = s0;
  end Fixed;

  model SpringDamper "Linear spring with rest length and a parallel damper"
    extends Interfaces.Compliant;
    parameter Types.TranslationalSpringConstant k "Stiffness";
    parameter Types.TranslationalDampingConstant c "Damping";
    parameter Types.Position s_rel0 "Rest length";
  equation
    f = k*(s_rel - s_rel0) + c*der(s_rel);
  end SpringDamper;

  model NodeMass "A lumped node mass of the stack's elements, frozen while the ground loop (mode LOCKED) holds the mechanics"
    parameter Types.Mass m "Mass";
    Interfaces.Flange flange;
    Interfaces.BooleanInput frozen "The mechanics are held (mode LOCKED)";
    Types.Position s(fixed = true) "Position";
    Types.Velocity v(start = 0, fixed = true) "Velocity";
  equation
    flange.s = s;
    der(s) = v;
    m*der(v) = if frozen then 0 else flange.f;
    when frozen then
      reinit(v, 0);
    end when;
  end NodeMass;

  model BrakeCarriage "Node 3 (the non-earth brake on the stack's end) and the runner, clamped by the two brakes: the modes and their jump conditions, and the brake disturbance (docs/model.md sections 2.2, 2.3, 2.5)"
    parameter Types.Mass m_node "Node 3: a sixth of the stack and the non-earth brake";
    parameter Types.Mass m_runner "Runner";
    parameter Types.Force F_d0 = 175 "Brake disturbance force in DRIVE";
    parameter Real gamma = 0 "Growth of the disturbance with the environment load";
    parameter Types.TranslationalSpringConstant k_e = 2e4 "Environment stiffness (the disturbance's load)";
    parameter Types.Position L_r = 0 "Runner rest position";
    Interfaces.Flange node "Node 3: the stack's end, the flexure and the transducer";
    Interfaces.Flange runner "The runner: the environment spring and the encoder";
    Interfaces.BooleanInput earthClosed "The earth brake clamps the runner to the ground";
    Interfaces.BooleanInput nonEarthClosed "The non-earth brake clamps the runner to node 3";
    Interfaces.BooleanOutput locked "Both brakes closed: the ground loop holds every mechanical state";
    Types.Position s_node(fixed = true) "Node 3 position";
    Types.Position s_runner(fixed = true) "Runner position";
    Types.Velocity v_node(start = 0, fixed = true) "Node 3 velocity";
    Types.Velocity v_runner(start = 0, fixed = true) "Runner velocity";
    Types.Force F_d "Brake disturbance (DRIVE only)";
    Types.Force F_drive "Net force on node 3 and the runner together";
    Boolean hold "Earth brake closed, non-earth open: the runner is held";
    Boolean drive "Earth brake open, non-earth closed: the runner rides on node 3";
    Boolean free "Both brakes open: the runner slips on the environment spring";
    Integer mode "1 HOLD, 2 LOCKED, 3 DRIVE, 4 FREE";
    Integer slip_events(start = 0, fixed = true) "Entries into FREE";
  equation
    node.s = s_node;
    runner.s = s_runner;
    hold = earthClosed and not nonEarthClosed;
    locked = earthClosed and nonEarthClosed;
    drive = not earthClosed and nonEarthClosed;
    free = not earthClosed and not nonEarthClosed;
    mode = if hold then 1 elseif locked then 2 elseif drive then 3 else 4;
    F_d = if drive then F_d0 - gamma*k_e*(s_runner - L_r) else 0;
    F_drive = node.f + runner.f + F_d;
    der(s_node) = v_node;
    der(s_runner) = v_runner;
    der(v_node) = if locked then 0 elseif drive then F_drive/(m_node + m_runner) else node.f/m_node;
    der(v_runner) = if drive then F_drive/(m_node + m_runner) elseif free then runner.f/m_runner else 0;
    when {locked, drive, hold} then
      reinit(v_node, if locked then 0 elseif drive then (m_node*pre(v_node) + m_runner*pre(v_runner))/(m_node + m_runner) else pre(v_node));
      reinit(v_runner, if drive then (m_node*pre(v_node) + m_runner*pre(v_runner))/(m_node + m_runner) else 0);
    end when;
    when free then
      slip_events = pre(slip_events) + 1;
    end when;
  end BrakeCarriage;
end Mechanics;
