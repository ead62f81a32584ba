use parry3d::shape::Ball;
#[test]
fn placeholder() { let _ = Ball::new(1.0); }
